"""Hair close-ups of the presets (or any characters): front, three-quarter and a top-down
view of the head, in the news lighting, as a contact sheet (docs/img/hair.png).

    python bench/hair_sheet.py [--only amara,mei] [--size 512] [-o docs/img/hair.png]
"""

from __future__ import annotations

import argparse
import math
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "src"))

import numpy as np
from PIL import Image

#: views: name → (azimuth °, elevation °, fill: share of the image height the face takes)
VIEWS: dict[str, tuple[float, float, float]] = {
    "front": (0.0, 0.0, 0.55),
    "three-quarter": (40.0, 5.0, 0.55),
    "above": (15.0, 55.0, 0.5),
}


def camera(head, view: str, size: int):
    """A camera on ``view`` (:data:`VIEWS`) around the head's face centre."""
    from mimika.render.camera import FOV_Y, Camera, face_frame

    az, el, fill = VIEWS[view]
    centre, height, _ = face_frame(head)
    centre = centre + np.array([0.0, 0.15 * height, -0.25 * height])  # the skull's middle
    dist = height / fill / 2.0 / math.tan(math.radians(FOV_Y) / 2.0)
    a, e = math.radians(az), math.radians(el)
    eye = centre + dist * np.array([math.sin(a) * math.cos(e), math.sin(e),
                                    math.cos(a) * math.cos(e)])
    return Camera(eye=eye, target=centre, up=np.array([0.0, 1.0, 0.0]), fov_y=FOV_Y,
                  aspect=1.0, near=0.3 * dist, far=3.0 * dist)


def render(character, size: int, views: tuple[str, ...] | None = None) -> list[np.ndarray]:
    """Images of ``character`` (a Character) in ``views`` (default: all :data:`VIEWS`)."""
    from mimika.face.heads.character import assemble, built_character
    from mimika.face.makehuman.paint import parts_of
    from mimika.render import Renderer
    from mimika.render.skin import SkinParams

    head, _ = assemble(built_character(character), character, lambda p: parts_of(p, character))
    with Renderer(head, (size, size), samples=4, skin_shader=SkinParams(),
                  lighting="news") as r:
        return [r.render(None, camera=camera(head, v, size)) for v in views or VIEWS]


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--only", help="comma-separated preset names (default: all)")
    ap.add_argument("--size", type=int, default=512)
    ap.add_argument("-o", "--out", type=Path, default=Path("docs/img/hair.png"))
    a = ap.parse_args()
    from mimika.face.makehuman.character_file import load_character_spec, preset_names
    from mimika.render.sheet import contact_sheet, save_png

    names = a.only.split(",") if a.only else preset_names()
    tiles, labels = [], []
    for n in names:
        ch = load_character_spec(n)
        for v, img in zip(VIEWS, render(ch, a.size), strict=True):
            tiles.append(img)
            labels.append(f"{n} · {ch.hair} · {v}")
    sheet = Image.fromarray(contact_sheet(tiles, labels, columns=len(VIEWS)))
    # 256 colours, dithered: a third of the size, the strands as fine (docs stay small)
    sheet = sheet.convert("RGB").quantize(256, method=Image.Quantize.MEDIANCUT,
                                          dither=Image.Dither.FLOYDSTEINBERG)
    a.out.parent.mkdir(parents=True, exist_ok=True)
    save_png(sheet, a.out)
    print(f"wrote {a.out}")


if __name__ == "__main__":
    main()
