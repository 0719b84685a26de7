"""glTF extensions mimika reads, one small module each, and what to do about the others.

:data:`SUPPORTED` is checked against a file's ``extensionsRequired``
(:func:`mimika.io.gltf_source.load_source`); :data:`REQUIRED_FIXES` is the one-line fix
named for the usual unsupported ones.
"""

from __future__ import annotations

__all__ = ["REQUIRED_FIXES", "SUPPORTED"]

#: extensions that may be required: decoded (meshopt, quantization, WebP) or
#: safe to read without (material variants of shading)
SUPPORTED = frozenset({
    "EXT_meshopt_compression", "KHR_meshopt_compression", "KHR_mesh_quantization",
    "EXT_texture_webp", "KHR_materials_unlit",
    "KHR_materials_emissive_strength", "KHR_materials_ior", "KHR_materials_specular",
    "KHR_materials_transmission", "KHR_materials_volume", "KHR_materials_clearcoat",
    "KHR_materials_sheen", "KHR_materials_variants",
})

_DECOMPRESS = ("decompress it first: npx @gltf-transform/cli copy in.glb out.glb, or "
               "npx @gltf-transform/cli meshopt in.glb out.glb (mimika reads meshopt)")
REQUIRED_FIXES = {
    "KHR_draco_mesh_compression": _DECOMPRESS,
    "KHR_texture_basisu": "convert its KTX2 textures: npx @gltf-transform/cli png in.glb "
                          "out.glb (or webp)",
    "EXT_texture_avif": "convert its AVIF textures: npx @gltf-transform/cli webp in.glb "
                        "out.glb",
}
