"""Rigs: AU intensities → vertex positions. :class:`FieldRig` (seed 002's displacement fields)
and :class:`BlendshapeRig` (weighted shape deltas, e.g. the ICT scans)."""

from mimika.face.rigs.blendshape import BlendshapeRig, ShapeSet
from mimika.face.rigs.field import FieldRig

__all__ = ["BlendshapeRig", "FieldRig", "ShapeSet"]
