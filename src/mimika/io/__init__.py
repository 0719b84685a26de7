"""File formats: Wavefront OBJ meshes."""

from mimika.io.obj import ObjMesh, read_obj, read_obj_vertices

__all__ = ["ObjMesh", "read_obj", "read_obj_vertices"]
