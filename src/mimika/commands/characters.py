"""``mimika characters``: the MakeHuman character presets, their assets, and contact sheets."""

from __future__ import annotations

import argparse


def _summary(c) -> str:
    ph = c.phenotype
    sex = "woman" if ph.get("gender", 0.5) < 0.5 else "man"
    origin = ", ".join(f"{k} {v / sum(ph['origin'].values()):.0%}"
                       for k, v in ph.get("origin", {}).items() if v)
    return (f"{sex}, {ph.get('age', 25):g} y, {origin or 'mixed'}; hair {c.hair or 'none'}, "
            f"{', '.join(c.clothes) or 'no clothes'}")


def cmd_characters(args: argparse.Namespace) -> int:
    from mimika.face.heads import DEFAULT_HEAD
    from mimika.face.makehuman.character_file import assets, load_character_spec, preset_names

    if args.assets:
        for kind in ("hair", "eyebrows", "eyelashes", "clothes"):
            print(f"{kind:<10} {', '.join(assets(kind))}")
        return 0
    if args.random is not None:
        from mimika.face.makehuman.people import random_people, write_people

        paths = write_people(random_people(args.random, args.seed), args.out)
        for path in paths:
            print(f"wrote {path}")
        print(f"\nUse them with --head {paths[0]}, in a batch spec (heads: [{args.out}/*.yaml]) "
              f"or on a sheet: mimika characters {args.out}/*.yaml --sheet people.png")
        return 0
    if args.modifiers:
        from mimika.face.makehuman.targets import modifiers

        groups: dict[str, list[str]] = {}
        for name, m in modifiers().items():
            if not name.startswith(("l-", "r-")):
                groups.setdefault(m.group, []).append(name + (" (0…1)" if not m.negative else ""))
        for group, names in groups.items():
            print(f"{group:<9} {', '.join(names)}")
        print("\nValues -1 … 1 (a shape marked 0…1 blends in from 0) under 'modifiers:' in a "
              "character file; l-NAME / r-NAME move one side (the character's left / right).")
        return 0
    if args.show:
        from importlib import resources

        c = load_character_spec(args.show)
        if c.source.startswith("preset "):
            print(resources.files("mimika.face").joinpath(
                "data", "characters", f"{c.name}.yaml").read_text("utf-8"), end="")
        else:
            with open(c.source, encoding="utf-8") as fh:
                print(fh.read(), end="")
        return 0
    if args.sheet:
        return _sheet(args)
    for name in preset_names():
        c = load_character_spec(name)
        mark = " (default)" if name == DEFAULT_HEAD else ""
        print(f"{name:<8} {_summary(c)}{mark}")
    print("\nUse one with --head NAME, or write a character file (mimika characters --show "
          f"{DEFAULT_HEAD} > me.yaml; edit; --head me.yaml). Assets: mimika characters --assets")
    return 0


def _sheet(args: argparse.Namespace) -> int:
    from mimika.face.heads import load_head
    from mimika.face.makehuman.character_file import preset_names
    from mimika.render import Renderer, contact_sheet
    from mimika.render.camera import frame_head
    from mimika.render.sheet import save_png

    names = args.names or preset_names()
    images, labels = [], []
    for name in names:
        head, rig = load_head(name)
        with Renderer(head, size=(320, 320), skin_shader=True) as r:
            for view in ("front", "three-quarter"):
                cam = frame_head(head, view, aspect=1.0, fill=0.55)
                images.append(r.render(rig.deform({}), camera=cam))
                labels.append(f"{head.name} ({view})")
    save_png(contact_sheet(images, labels, columns=4, title="mimika characters"), args.sheet)
    print(f"wrote {args.sheet}")
    return 0


def register(sub) -> None:
    p = sub.add_parser("characters", help="list the character presets (MakeHuman people)")
    p.add_argument("names", nargs="*", help="presets or character files for --sheet")
    p.add_argument("--show", metavar="NAME", help="print a preset's (or file's) character file")
    p.add_argument("--assets", action="store_true",
                   help="list the hair, brows, lashes and clothes a character file may name")
    p.add_argument("--modifiers", action="store_true",
                   help="list the face modifiers (MakeHuman's sliders) a character file may set")
    p.add_argument("--sheet", metavar="PNG", help="write a contact sheet of the characters")
    p.add_argument("--random", type=int, metavar="N",
                   help="write N random people (sex, age, origin, face, hair, clothes) as "
                        "character files into --out")
    p.add_argument("--seed", type=int, default=0, help="random seed of --random (default 0)")
    p.add_argument("--out", default="people", metavar="DIR",
                   help="folder for --random's files (default: people)")
    p.set_defaults(func=cmd_characters)
