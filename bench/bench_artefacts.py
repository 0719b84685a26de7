"""Artefacts of dressed characters: each preset and a generated cast (every clothes and hair
asset, ages 18–80, every origin mix) at rest, in AU poses, head turns and body moves, checked
in the newsreader's HD shot (:func:`mimika.render.artefacts.check_frame`).

    python bench/bench_artefacts.py [--only amara,mei] [--random 8] [--sheet docs/img/artefacts.png]

Prints, per character and pose, the offending pixels (visible cloth on triangles that pass
through cloth or skin; skin seen through clothes or through gaps between hair cards;
z-fighting) and triangles (cloth through cloth, skin through cloth, edges stretched over 2×,
flipped), then the totals.
The sheet shows each character in four poses, offending pixels outlined in magenta.
"""

from __future__ import annotations

import argparse
import itertools
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "src"))

import numpy as np
from PIL import Image

#: poses: AU / body channel → value (head turns at 0.6: 21° left/right, 15° up/down)
POSES: dict[str, dict[str, float]] = {
    "rest": {},
    "speak": {"AU25": 1.0, "AU26": 1.0, "AU12": 0.5},
    "jaw drop": {"AU27": 1.0},
    "surprise": {"AU01": 1.0, "AU02": 1.0, "AU05": 0.8, "AU26": 0.6},
    "smile": {"AU06": 1.0, "AU12": 1.0},
    "turn left": {"AU51": 0.6},
    "turn right": {"AU52": 0.6},
    "look up": {"AU53": 0.6},
    "look down": {"AU54": 0.6},
    "tilt": {"AU55": 0.6},
    "shrug": {"body.shrug_l": 1.0, "body.shrug_r": 1.0, "body.breath": 1.0},
    "lean+turn": {"body.lean_fwd": 1.0, "body.turn_l": 1.0, "AU51": 0.3},
}
#: the poses shown on the sheet
SHEET_POSES = ("rest", "jaw drop", "turn left", "shrug")
AGES = (18, 30, 45, 60, 72, 80)
ORIGINS = ({"african": 1.0}, {"asian": 1.0}, {"caucasian": 1.0},
           {"african": 0.5, "caucasian": 0.5}, {"african": 0.5, "asian": 0.5},
           {"asian": 0.3, "caucasian": 0.7})
SIZE = (1280, 720)


def cast(random: int = 0) -> list:
    """The presets, then one generated character per clothes asset: ages, origin mixes,
    builds and hair styles rotate so every asset and mix appears; then ``random`` random
    people (:mod:`mimika.face.makehuman.people`, seed 0: faces of their own too)."""
    from mimika.face.makehuman.character_file import (
        assets,
        character_from_dict,
        load_character_spec,
        preset_names,
    )

    out = [load_character_spec(n) for n in preset_names()]
    hair = itertools.cycle(assets("hair"))
    for k, clothes in enumerate(assets("clothes")):
        male = clothes.startswith("male")
        doc = {"name": f"gen{k}-{clothes.split('_')[1]}",
               "phenotype": {"gender": 1.0 if male else 0.0, "age": AGES[k % len(AGES)],
                             "weight": (0.3, 0.8, 0.5)[k % 3], "muscle": (0.7, 0.3, 0.5)[k % 3],
                             "origin": ORIGINS[k % len(ORIGINS)]},
               "hair": {"style": next(hair), "color": "#3a2a20"}, "clothes": [clothes]}
        out.append(character_from_dict(doc, f"generated {k}"))
    from mimika.face.makehuman.people import random_people

    out += [character_from_dict(d, d["name"]) for d in random_people(random)] if random else []
    return out


def load(character):
    from mimika.face.heads.character import assemble, built_character
    from mimika.face.makehuman.paint import parts_of

    return assemble(built_character(character), character, lambda p: parts_of(p, character))


def outline(img: np.ndarray, mask: np.ndarray) -> np.ndarray:
    """``img`` with the border of ``mask`` (grown by 2 px) in magenta and its inside tinted."""
    from scipy import ndimage

    grown = ndimage.binary_dilation(mask, iterations=2)
    edge = grown & ~ndimage.binary_erosion(grown, iterations=2)
    out = img.copy()
    out[grown] = (0.6 * out[grown] + 0.4 * np.array([255, 0, 255])).astype(np.uint8)
    out[edge] = (255, 0, 255)
    return out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--only", help="comma-separated character names")
    ap.add_argument("--sheet", type=Path, help="write the contact sheet here (PNG)")
    ap.add_argument("--random", type=int, default=0, metavar="N",
                    help="also N random people (mimika characters --random, seed 0)")
    a = ap.parse_args()
    from mimika.newsreader.pipeline import news_camera
    from mimika.render import Renderer
    from mimika.render.artefacts import check_frame
    from mimika.render.lighting import NEWS
    from mimika.render.sheet import contact_sheet
    from mimika.render.skin import SkinParams

    only = set(a.only.split(",")) if a.only else None
    totals: dict[str, int] = {}
    tiles, labels = [], []
    keys = ("cloth_cross_px", "skin_through_px", "hair_gap_px", "zfight_px",
            "cloth_cloth_tris", "skin_cloth_tris", "stretched_tris", "flipped_tris")
    print(f"{'character':<22} {'pose':<11} " + " ".join(f"{k:>16}" for k in keys))
    for ch in cast(a.random):
        if only and ch.name not in only:
            continue
        t0 = time.perf_counter()
        head, rig = load(ch)
        cam = news_camera(head, "front", SIZE[0] / SIZE[1])
        rend = Renderer(head, SIZE, samples=4, skin_shader=SkinParams(), lighting="news") \
            if a.sheet else None
        for pose, aus in POSES.items():
            pos = rig.deform(aus) if aus else None
            fc = check_frame(head, pos, cam, SIZE, desk=NEWS.desk)
            c = fc.counts()
            for k, v in c.items():
                totals[k] = totals.get(k, 0) + v
            print(f"{ch.name:<22} {pose:<11} " + " ".join(f"{c[k]:>16}" for k in keys),
                  flush=True)
            if rend is not None and pose in SHEET_POSES:
                img = outline(rend.render(pos, camera=cam), fc.mask())
                w, h = SIZE
                tiles.append(img[int(0.08 * h):int(0.98 * h), int(0.25 * w):int(0.75 * w)])
                bad = c["cloth_cross_px"] + c["skin_through_px"] + c["zfight_px"]
                labels.append(f"{ch.name} · {pose} · {bad} px")
        if rend is not None:
            rend.close()
        print(f"{'':<22} ({ch.description or ch.source}; {time.perf_counter() - t0:.0f} s)")
    print("total".ljust(34) + " ".join(f"{totals.get(k, 0):>16}" for k in keys))
    if a.sheet and tiles:
        small = [np.asarray(Image.fromarray(t).resize((320, 320 * t.shape[0] // t.shape[1]),
                                                      Image.Resampling.LANCZOS)) for t in tiles]
        sheet = Image.fromarray(contact_sheet(
            small, labels, columns=len(SHEET_POSES),
            title="Characters in the news shot: offending pixels outlined in magenta"))
        a.sheet.parent.mkdir(parents=True, exist_ok=True)
        from mimika.render.sheet import save_png

        save_png(sheet.quantize(256, method=Image.Quantize.MEDIANCUT,
                                dither=Image.Dither.FLOYDSTEINBERG).convert("RGB"), a.sheet)
        print(f"wrote {a.sheet}")


if __name__ == "__main__":
    main()
