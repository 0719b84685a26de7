"""Faces: head geometry, rigs (FieldRig, BlendshapeRig) and the heads mimika ships or loads."""

from mimika.face.head import Head, MeshObject, Part
from mimika.face.rig import Rig

__all__ = ["Head", "MeshObject", "Part", "Rig"]
