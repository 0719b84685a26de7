"""``mimika rig`` (give a face mesh FACS and ARKit blendshapes) and ``mimika heads --inspect``
(what a character's morphs cover)."""

from __future__ import annotations

import argparse
from pathlib import Path

from mimika.errors import ParameterError

STYLES = ("ict", "makehuman")  #: mimika.face.rigging.generate.STYLES (kept light for --help)


def cmd_rig(args: argparse.Namespace) -> int:
    from mimika.face.rigging.autorig import rig_mesh
    from mimika.face.rigging.export import arkit_shapes, write_rigged

    out = Path(args.output)
    if out.suffix.lower() not in (".glb", ".gltf"):
        raise ParameterError(f"output {str(out)!r} must end in .glb or .gltf")
    if not 0.1 <= args.strength <= 3.0:
        raise ParameterError(f"--strength {args.strength:g} must be within 0.1 and 3")
    r = rig_mesh(args.mesh, landmarks=args.landmarks, style=args.style, strength=args.strength)
    path, arkit = write_rigged(out, r.rig, arkit_shapes(r.shapes))
    head = r.head
    aus = [c for c in r.rig.supported if len(c) == 4]
    if not args.quiet:
        print(f"face: {r.frame.describe()} (for animating; the file stays where it is)")
        print("objects: " + ", ".join(f"{o.name} ({o.category}, {o.n_vertices} vertices)"
                                      for o in head.objects))
        n_meshes = len(head.meta["gltf"].scene.meshes)
        print(f"kept: the input's {n_meshes} mesh{'es' if n_meshes > 1 else ''} as they were "
              "(place, vertex order, UVs, materials), morph targets added")
        print(f"wrote {path}: {len(aus)} AUs ({len([c for c in r.rig.supported if len(c) > 4])}"
              f" one-sided), {len(arkit)} ARKit shapes in {sum(r.seconds.values()):.1f} s")
        missing = [a for a in ("tongueOut",) if a not in arkit]
        if missing:
            print(f"not generated: {', '.join(missing)} (no fitted field: neither the ICT scans "
                  "nor the MakeHuman faceunits move a tongue)")
    return 0


def inspect_head(path: str) -> int:
    from mimika.face.heads import load_head
    from mimika.face.heads.roles import motion as role_motion

    head, rig = load_head(path)
    roles, how = head.meta.get("roles", {}), head.meta.get("role_how", {})
    print(f"{path}: {len(head.objects)} objects: " + ", ".join(
        f"{o.name} ({roles.get(o.name, o.category)})" for o in head.objects))
    if roles:
        print(f"\n{'object':<24}{'role':<9}{'category':<10}{'fields':<8}from")
        for o in head.objects:
            r = roles[o.name]
            print(f"{o.name[:23]:<24}{r:<9}{o.category:<10}{role_motion(r):<8}"
                  f"{how.get(o.name, '')}")
        print()
    print(f"frame: {head.meta.get('frame', '')}")
    for note in head.meta.get("pose", []):
        print(f"pose: {note} (arms hang for the head-and-shoulders shot)")
    if head.meta.get("head_bone"):
        print(f"head AUs follow the skin's bone {head.meta['head_bone']!r}")
    cover = head.meta.get("coverage", {})
    counts: dict[str, int] = {}
    print(f"\n{'AU':<6}{'source':<10}how")
    for code in (c for c in rig.supported if len(c) == 4):
        src, how = cover.get(code, ("?", ""))
        counts[src] = counts.get(src, 0) + 1
        print(f"{code:<6}{src:<10}{how}")
    print("\n" + ", ".join(f"{n} {k}" for k, n in counts.items()))
    rows = head.meta.get("morphs", [])
    if rows:
        print(f"\n{'mesh':<20}{'morph':<28}{'kind':<11}{'as':<18}rule")
        for r in rows:
            print(f"{r['mesh'][:19]:<20}{r['morph'][:27]:<28}{r['kind']:<11}{r['as']:<18}"
                  f"{r['how']}")
    return 0


def register(sub) -> None:
    r = sub.add_parser("rig", help="give a face mesh (OBJ, glTF, VRM) FACS AU and ARKit-52 "
                       "blendshapes, written as GLB")
    r.add_argument("mesh", help="the mesh: .obj, .glb, .gltf or .vrm")
    r.add_argument("-o", "--output", required=True, help="the rigged .glb (or .gltf)")
    r.add_argument("--landmarks", help="JSON with eye_L, eye_R and mouth [x, y, z] in the "
                   "mesh's coordinates, for faces whose eyes and mouth are not found")
    r.add_argument("--style", choices=STYLES, default="ict",
                   help="whose shapes the fields were fitted on: ict (light-stage scans of an "
                   "actor, strong; default) or makehuman (artist-made faceunits, about half "
                   "as strong)")
    r.add_argument("--strength", type=float, default=1.0, help="a factor on every generated "
                   "shape (default 1; 0.7 brings the ict style to a MakeHuman-like head's own "
                   "strength, see docs/avatars.md)")
    r.add_argument("-q", "--quiet", action="store_true", help="print nothing")
    r.set_defaults(func=cmd_rig)
