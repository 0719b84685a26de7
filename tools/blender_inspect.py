"""Import a glTF/GLB into an empty Blender scene and print what Blender made of it, as JSON.

usage: blender -b --factory-startup -noaudio --python-exit-code 1 \
         --python tools/blender_inspect.py -- FILE.glb [--mimika-timing]

``--mimika-timing`` imports the way docs/formats.md tells Blender users to: the scene's frame
rate is set from the file's ``scenes[0].extras.fps`` *before* the import (Blender converts
glTF seconds to frames at the scene rate), the frame range from ``frame_start/frame_end``
after it. The report (one line ``BLENDER_REPORT {json}``) lists the scene, objects (type,
parent, shape keys, vertex groups, modifiers, materials), armatures and their bones, actions
with their frame ranges, materials and images. Used by tests/blender_app.py.
"""

import json
import struct
import sys

import bpy
import numpy

if not hasattr(numpy, "bool"):  # Debian's Blender 3.4 glTF importer still uses np.bool
    numpy.bool = bool


def gltf_json(path):
    """The JSON part of a .glb or .gltf file."""
    with open(path, "rb") as f:
        data = f.read()
    if data[:4] == b"glTF":
        (length,) = struct.unpack_from("<I", data, 12)
        return json.loads(data[20:20 + length])
    return json.loads(data)


def import_mimika_gltf(path):
    """Import a mimika glTF with its frame rate and range (the docs/formats.md recipe)."""
    scene = bpy.context.scene
    extras = gltf_json(path).get("scenes", [{}])[0].get("extras", {})
    fps = float(extras.get("fps", scene.render.fps))
    scene.render.fps = round(fps)
    scene.render.fps_base = round(fps) / fps
    bpy.ops.import_scene.gltf(filepath=path)
    if "frame_end" in extras:
        scene.frame_start = int(extras["frame_start"])
        scene.frame_end = int(extras["frame_end"])


def report():
    scene = bpy.context.scene

    def props(idb):
        return {k: idb[k] if isinstance(idb[k], (int, float, str)) else str(idb[k])
                for k in idb.keys() if not k.startswith("_")}  # noqa: SIM118 (ID props)

    objects = []
    for o in bpy.data.objects:
        ob = {"name": o.name, "type": o.type, "parent": o.parent.name if o.parent else None,
              "props": props(o), "modifiers": [m.type for m in o.modifiers],
              "action": (o.animation_data.action.name
                         if o.animation_data and o.animation_data.action else None)}
        if o.type == "MESH":
            me = o.data
            keys = me.shape_keys
            ob.update({
                "mesh": me.name, "vertices": len(me.vertices), "polygons": len(me.polygons),
                "vertex_groups": [g.name for g in o.vertex_groups],
                "materials": [m.name for m in me.materials if m],
                "shape_keys": [k.name for k in keys.key_blocks] if keys else [],
                "shape_key_action": (keys.animation_data.action.name
                                     if keys and keys.animation_data
                                     and keys.animation_data.action else None),
                "uv_layers": [u.name for u in me.uv_layers],
            })
        if o.type == "ARMATURE":
            ob["bones"] = [b.name for b in o.data.bones]
        objects.append(ob)
    actions = [{"name": a.name, "id_root": a.id_root, "frame_range": list(a.frame_range),
                "fcurves": len(a.fcurves),
                "data_paths": sorted({fc.data_path for fc in a.fcurves})[:50]}
               for a in bpy.data.actions]
    materials = [{"name": m.name, "use_nodes": m.use_nodes,
                  "textures": sorted({n.image.name for n in (m.node_tree.nodes if m.node_tree
                                                              else [])
                                      if n.type == "TEX_IMAGE" and n.image})}
                 for m in bpy.data.materials]
    return {"blender": bpy.app.version_string,
            "scene": {"fps": scene.render.fps, "fps_base": scene.render.fps_base,
                      "frame_start": scene.frame_start, "frame_end": scene.frame_end,
                      "props": props(scene)},
            "objects": objects, "actions": actions, "materials": materials,
            "images": [{"name": i.name, "size": list(i.size)} for i in bpy.data.images]}


def main():
    argv = sys.argv[sys.argv.index("--") + 1:] if "--" in sys.argv else []
    if not argv:
        raise SystemExit("usage: blender -b --python tools/blender_inspect.py -- FILE.glb "
                         "[--mimika-timing]")
    path = argv[0]
    bpy.ops.wm.read_factory_settings(use_empty=True)
    if "--mimika-timing" in argv:
        import_mimika_gltf(path)
    else:
        bpy.ops.import_scene.gltf(filepath=path)
    print("BLENDER_REPORT " + json.dumps(report()), flush=True)


main()
