"""``mimika aus`` and ``mimika heads``: what mimika knows and what it can animate."""

from __future__ import annotations

import argparse
import json


def cmd_aus(args: argparse.Namespace) -> int:
    from mimika.face.rigs.blendshape import load_table
    from mimika.face.rigs.field import load_fields
    from mimika.facs import AU_CATALOGUE

    builtin = set(load_fields().aus)
    ict = set(load_table()["aus"])
    character = set(load_table("makehuman_aus.json")["aus"])
    rows = []
    for code, au in AU_CATALOGUE.items():
        if args.modelled and code not in builtin | ict | character:
            continue
        rows.append({
            "code": code, "name": au.name, "group": au.group, "objects": list(au.objects),
            "kind": au.kind, "subobject": au.subobject, "seed": au.seed,
            "sides": [code + "L", code + "R"] if au.sided else [],
            "builtin": code in builtin, "ict": code in ict, "character": code in character,
        })
    if args.json:
        print(json.dumps(rows, indent=1))
        return 0
    print(f"{'code':<6}{'name':<26}{'group':<20}{'objects':<17}{'L/R':<5}"
          f"{'seed':<6}{'character':<11}{'builtin':<9}ict")
    for r in rows:
        yes = {True: "yes", False: "-"}
        print(f"{r['code']:<6}{r['name']:<26}{r['group']:<20}{';'.join(r['objects']):<17}"
              f"{yes[bool(r['sides'])]:<5}{yes[r['seed']]:<6}{yes[r['character']]:<11}"
              f"{yes[r['builtin']]:<9}{yes[r['ict']]}")
    n_c = sum(r["character"] for r in rows)
    n_b = sum(r["builtin"] for r in rows)
    n_i = sum(r["ict"] for r in rows)
    print(f"\n{len(rows)} AUs; modelled: characters {n_c}, builtin {n_b}, ict {n_i}. "
          "Unilateral variants: append L or R (AU12L). Input also accepts 12, au12, AU1.")
    return 0


def cmd_heads(args: argparse.Namespace) -> int:
    from mimika.face.heads import list_heads

    if args.inspect:
        from mimika.commands.avatar import inspect_head

        return inspect_head(args.inspect)

    for h in list_heads():
        mark = "available" if h.available else "missing"
        print(f"{h.name:<8} {h.rig:<13} {mark:<10} {h.description}")
    return 0


def register(sub) -> None:
    a = sub.add_parser("aus", help="list the FACS Action Units and which heads model them")
    a.add_argument("--modelled", action="store_true", help="only AUs some head models")
    a.add_argument("--json", action="store_true", help="machine-readable output")
    a.set_defaults(func=cmd_aus)

    h = sub.add_parser("heads", help="list the heads mimika can animate")
    h.add_argument("--inspect", metavar="FILE", help="a character file (.glb, .gltf, .vrm): "
                   "which AUs its morphs cover and how, which come from fields")
    h.set_defaults(func=cmd_heads)
