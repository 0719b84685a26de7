"""Render the images of docs/fitting.md from fitted fields files.

    MIMIKA_ICT_DIR=… python scripts/fit_images.py --fields fields_rich.json --out docs/img

Writes fit_aus_<family>.png (per fitted AU: ICT shapes | fitted fields on the ICT head | the
same fields carried to the built-in head) and fit_identities.png (happiness on six ICT
identities with the BlendshapeRig and the fitted FieldRig).
"""

from __future__ import annotations

import argparse
from pathlib import Path

from mimika.face.fitting import load_fitted_rig
from mimika.face.heads.builtin import build_builtin_head
from mimika.face.heads.ict import load_ict_head
from mimika.face.rigs.blendshape import load_ict_rig
from mimika.knowledge.expressions import expression_aus
from mimika.render import Renderer, contact_sheet, save_png

#: identities of the sheet: the generic face and five mixtures of the first identity modes
IDENTITIES = {
    "generic": None,
    "A": [3, 0, 0, 0, 0, 0],
    "B": [-3, 2, 0, 0, 0, 0],
    "C": [0, -3, 2, 0, 0, 0],
    "D": [0, 0, -2, 3, 0, 0],
    "E": [1, 0, 0, -3, 3, -2],
}


def _render(rig, aus, size, view="front"):
    with Renderer(rig.head, size=size) as r:
        return r.render(rig.deform(aus), view=view)


def au_sheet(fields: str, family: str, out: Path, aus: list[str] | None, view: str) -> Path:
    ict = load_ict_rig()
    fit_ict = load_fitted_rig(ict.head, fields)
    builtin = load_fitted_rig(build_builtin_head(1), fields)
    codes = aus or [c for c in fit_ict.fields.aus if c in fit_ict.fields.linear]
    imgs, labels = [], []
    size = (160, 160)
    for code in codes:
        for rig, who in ((ict, "ICT shapes"), (fit_ict, f"ICT {family}"),
                         (builtin, f"builtin {family}")):
            imgs.append(_render(rig, {code: 1.0}, size, view))
            labels.append(f"{code} {who}")
    path = out / f"fit_aus_{family}{'' if view == 'front' else '_' + view}.png"
    save_png(contact_sheet(imgs, labels, columns=6,
                           title=f"fitted AU fields ({family}): scan | fit | built-in head"),
             path)
    return path


def identity_sheet(fields: str, out: Path, expression: str = "happiness") -> Path:
    aus = expression_aus(expression, 1.0)
    imgs, labels = [], []
    size = (220, 220)
    for kind in ("BlendshapeRig", "FieldRig"):
        for name, w in IDENTITIES.items():
            if kind == "BlendshapeRig":
                rig = load_ict_rig(identity=w)
            else:
                rig = load_fitted_rig(load_ict_head(identity=w), fields)
            keep = {k: v for k, v in aus.items() if k in rig.supported}
            imgs.append(_render(rig, keep, size))
            labels.append(f"{name} · {kind}")
    path = out / "fit_identities.png"
    save_png(contact_sheet(imgs, labels, columns=len(IDENTITIES),
                           title=f"{expression} on six ICT identities: scan shapes (top), "
                                 "fitted fields (bottom)"), path)
    return path


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__)
    p.add_argument("--fields", required=True)
    p.add_argument("--family", default="rich")
    p.add_argument("--out", default="docs/img")
    p.add_argument("--au", action="append")
    p.add_argument("--view", default="front")
    p.add_argument("--no-identities", action="store_true")
    a = p.parse_args()
    out = Path(a.out)
    out.mkdir(parents=True, exist_ok=True)
    print(au_sheet(a.fields, a.family, out, a.au, a.view))
    if not a.no_identities:
        print(identity_sheet(a.fields, out))


if __name__ == "__main__":
    main()
