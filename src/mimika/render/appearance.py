"""What mimika's look adds to a head, as vertex data for files other programs render (glTF).

* ``COLOR_0`` — the inside of the mouth darkened by depth for a half-open mouth, skin there
  tinted toward the oral mucosa (:mod:`.mouth`); 1 elsewhere. glTF viewers (three.js,
  Blender) multiply the base colour by it.
* ``_FACE`` — on the face, the place of each vertex in face units (x, y) and how much of the
  face it is (:mod:`.wrinkles`): what mimika's studio viewer draws the wrinkles with, with
  the document's ``extras.wrinkles``.
"""

from __future__ import annotations

import numpy as np

from mimika.face.head import Head
from mimika.render.mouth import MouthCavity
from mimika.render.wrinkles import Wrinkles

#: skin inside the mouth, as a factor on the skin's colour (reddish and darker)
MUCOSA_TINT = np.array([1.0, 0.55, 0.5], np.float32)


def export_appearance(head: Head) -> tuple[dict[str, dict[str, np.ndarray]], dict]:
    """``(attributes, extras)`` for :func:`mimika.io.gltf.write_gltf`: {object: {glTF
    attribute: (N, 3) float32}} and ``{"wrinkles": …}`` (:meth:`Wrinkles.description`)."""
    mouth = MouthCavity(head)
    out: dict[str, dict[str, np.ndarray]] = {}
    for name, vis in mouth.shade().items():
        o = head[name]
        col = np.ones((o.n_vertices, 3), np.float32)
        col[mouth.ids[name]] = vis[:, None]
        if o.category == "face":  # skin or a cavity mesh: the mucosa's colour
            w = mouth.inside[name][:, None]
            col[mouth.ids[name]] *= 1.0 - w + w * MUCOSA_TINT
        out[name] = {"COLOR_0": col}
    wr = Wrinkles(head)
    out.setdefault(head.landmark_object, {})["_FACE"] = wr.face
    return out, {"wrinkles": wr.description()}
