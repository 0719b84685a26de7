"""Contact sheets of the painted MakeHuman characters (docs/img/character-*.png).

    PYTHONPATH=src python scripts/character_sheets.py [--out docs/img] [--size 300]

Writes, per preset, front / three-quarter / profile with the standard shader (top row) and the
texture-space skin shader under the news lighting (bottom row); ``character-paint-aus.png``
(each preset neutral, AU12+AU06, AU27, AU01+AU02 — the paint must stay put); and
``character-paint-assets.png`` (every hair style, brow, lash set and outfit on one character).
"""

from __future__ import annotations

import argparse
import sys
from dataclasses import replace
from pathlib import Path

import numpy as np
from PIL import Image, ImageDraw

from mimika.face.heads import load_head
from mimika.face.heads.character import assemble, built_character
from mimika.face.makehuman.character_file import assets, load_character_spec, preset_names
from mimika.face.makehuman.paint import parts_of
from mimika.render import Renderer
from mimika.render.camera import frame_head
from mimika.render.lighting import NEWS as NEWS_LIGHTING

VIEWS = ("front", "three-quarter", "profile")
POSES = {"neutral": {}, "AU12+AU06": {"AU12": 1.0, "AU06": 1.0}, "AU27": {"AU27": 1.0},
         "AU01+AU02": {"AU01": 1.0, "AU02": 1.0}}


def _label(img: np.ndarray, text: str) -> np.ndarray:
    im = Image.fromarray(img)
    ImageDraw.Draw(im).text((6, 4), text, fill=(235, 235, 235))
    return np.asarray(im)


def _zoom(cam, z: float, dy: float = 0.0):
    t = cam.target + np.array([0.0, dy, 0.0])
    return replace(cam, eye=t + (cam.eye - cam.target) / z, target=t, near=cam.near / z)


def sheet(head, rig, size: int) -> np.ndarray:
    rows = []
    for skin in (False, True):
        kw = {"skin_shader": True, "lighting": NEWS_LIGHTING} if skin else {}
        with Renderer(head, (size, size), samples=4, **kw) as r:
            rows.append(np.concatenate(
                [r.render(None, camera=frame_head(head, v, aspect=1.0, fill=0.5))
                 for v in VIEWS], 1))
    return np.concatenate(rows, 0)


def au_sheet(names: list[str], size: int) -> np.ndarray:
    rows = []
    for n in names:
        head, rig = load_head(n)
        with Renderer(head, (size, size), samples=4) as r:
            cam = _zoom(frame_head(head, "front", aspect=1.0, fill=1.0), 1.25, -1.0)
            rows.append(np.concatenate([_label(r.render(rig.deform(aus), camera=cam),
                                               f"{n} {k}") for k, aus in POSES.items()], 1))
    return np.concatenate(rows, 0)


def assets_sheet(base: str, size: int) -> np.ndarray:
    """Every hair style, brow, lash set and outfit, each on ``base``."""
    ch = load_character_spec(base)
    tiles = []

    def shot(c, view, fill, zoom=1.0, dy=0.0, label=""):
        head, _ = assemble(built_character(c), c, lambda p: parts_of(p, c))
        with Renderer(head, (size, size), samples=4) as r:
            cam = _zoom(frame_head(head, view, aspect=1.0, fill=fill), zoom, dy)
            tiles.append(_label(r.render(None, camera=cam), label))

    for h in assets("hair"):
        shot(replace(ch, hair=h), "three-quarter", 0.7, label=h)
    for b in assets("eyebrows"):
        shot(replace(ch, eyebrows=b, hair=None), "front", 1.0, 3.0, 2.2, b)
    for e in assets("eyelashes"):
        shot(replace(ch, eyelashes=e, hair=None), "three-quarter", 1.0, 4.0, 1.6, e)
    for o in assets("clothes"):
        shot(replace(ch, clothes=(o,)), "front", 0.3, label=o)
    cols = 6
    while len(tiles) % cols:
        tiles.append(np.zeros_like(tiles[0]))
    return np.concatenate([np.concatenate(tiles[i:i + cols], 1)
                           for i in range(0, len(tiles), cols)], 0)


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", default="docs/img")
    ap.add_argument("--size", type=int, default=300)
    ap.add_argument("--only", choices=("presets", "aus", "assets"), default=None)
    a = ap.parse_args(argv)
    out = Path(a.out)
    out.mkdir(parents=True, exist_ok=True)
    names = preset_names()
    if a.only in (None, "presets"):
        for n in names:
            head, rig = load_head(n)
            Image.fromarray(sheet(head, rig, a.size)).save(out / f"character-{n}.png",
                                                          optimize=True)
    if a.only in (None, "aus"):
        Image.fromarray(au_sheet(names, a.size * 3 // 4)).save(
            out / "character-paint-aus.png", optimize=True)
    if a.only in (None, "assets"):
        Image.fromarray(assets_sheet("amara", a.size * 2 // 3)).save(
            out / "character-paint-assets.png", optimize=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
