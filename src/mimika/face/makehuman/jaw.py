"""What an opening jaw carries besides the lower teeth: the tongue.

MakeHuman's ``jawOpen`` target drops the lower teeth row (26 mm at its front incisors at full
opening) and turns the tongue about a pivot above its root: the tip drops with the incisors,
the back stays at the palate's height. An open mouth then showed a wall of tongue filling the
whole opening — every spoken vowel, AU26 and AU27 alike — where a photograph shows the tongue
low behind the lower teeth and the dark of the mouth above it.
"""

from __future__ import annotations

import dataclasses

import numpy as np

from mimika.face.makehuman.build import Built
from mimika.face.makehuman.teeth import front_incisors, rows


def tongue_follows_jaw(built: Built) -> Built:
    """``built`` with the tongue flattening as the jaw drops: its top comes down with
    ``jawOpen`` as far as the lower incisors, its underside keeps MakeHuman's motion (it lies
    on the floor of the mouth), and the share between them follows the height."""
    teeth = next((p for p in built.pieces if p.name == "teeth"), None)
    tongue = next((p for p in built.pieces if p.name == "tongue"), None)
    if teeth is None or tongue is None or "jawOpen" not in built.shape_names:
        return built
    k = built.shape_names.index("jawOpen")
    front = front_incisors(built, teeth, rows(built))
    if not front.any():
        return built
    drop = float(built.deltas["teeth"][k][front, 1].mean())
    y = tongue.vertices[:, 1].astype(np.float64)
    height = (y - y.min()) / max(float(np.ptp(y)), 1e-9)  # 0 underside … 1 top
    d = built.deltas["tongue"].copy()
    d[k, :, 1] += (np.minimum(0.0, drop - d[k, :, 1]) * height).astype(d.dtype)
    return dataclasses.replace(built, deltas={**built.deltas, "tongue": d})
