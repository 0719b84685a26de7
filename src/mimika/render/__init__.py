"""Headless rendering of heads: :class:`Renderer`, cameras, PNG output and contact sheets.

OpenGL (moderngl on Mesa EGL) is only touched when a renderer first draws.
"""

from mimika.render.camera import VIEWS, Camera, frame_head
from mimika.render.renderer import Renderer, vertex_normals
from mimika.render.sheet import contact_sheet, save_png

__all__ = [
    "VIEWS", "Camera", "Renderer", "contact_sheet", "frame_head", "save_png", "vertex_normals",
]
