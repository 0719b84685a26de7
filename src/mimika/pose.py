"""Still images of AU poses: one pose, or a labelled contact sheet of every modelled AU."""

from __future__ import annotations

from collections.abc import Callable, Mapping
from pathlib import Path
from typing import Any

import numpy as np

from mimika.face.rig import Rig
from mimika.facs import AU_CATALOGUE, base_code, parse_au_values
from mimika.render.camera import FILL

Progress = Callable[[int, int], None]


def _rig(head: str | Path | Rig | None, fields: str | Path | None) -> Rig:
    if isinstance(head, Rig):
        return head
    from mimika.face.heads import DEFAULT_HEAD, load_head

    return load_head(DEFAULT_HEAD if head is None else head, fields=fields)[1]


def render_pose(
    aus: Mapping[str, float] | list[str],
    *,
    head: str | Path | Rig | None = None,
    view: str = "front",
    size: tuple[int, int] = (640, 480),
    fields: str | Path | None = None,
    samples: int = 4,
    lighting: Any = None,
    fill: float = FILL,
) -> np.ndarray:
    """Render ``aus`` (``{"AU12": 1}`` or ``["AU12=1"]``) on ``head`` (default: the default
    character) with their appearance changes, lit by ``lighting`` (a ``--light`` spec or a
    :class:`~mimika.render.lighting.Lighting`; default ``studio``), the face filling
    ``fill`` of the image height (default: a portrait); returns
    (H, W, 3) uint8."""
    from mimika.render import Renderer

    rig = _rig(head, fields)
    vals = rig.check(parse_au_values(aus))
    with Renderer(rig.head, size=size, samples=samples, lighting=lighting, fill=fill) as r:
        return r.render(rig.deform(vals), view=view, aus=vals)


def au_sheet(
    *,
    head: str | Path | Rig | None = None,
    view: str = "front",
    tile: tuple[int, int] = (256, 256),
    columns: int = 8,
    fields: str | Path | None = None,
    progress: Progress | None = None,
    lighting: Any = None,
    fill: float = FILL,
) -> np.ndarray:
    """A labelled contact sheet: neutral, then one tile per modelled AU at full intensity."""
    from mimika.render import Renderer, contact_sheet

    rig = _rig(head, fields)
    codes = list(rig.supported_bilateral)
    images, labels = [], []
    with Renderer(rig.head, size=tile, lighting=lighting, fill=fill) as r:
        for i, code in enumerate([None, *codes]):
            aus = {code: 1.0} if code else {}
            images.append(r.render(rig.deform(aus), view=view, aus=aus))
            labels.append(f"{code} {AU_CATALOGUE[base_code(code)].name}" if code else "neutral")
            if progress:
                progress(i + 1, len(codes) + 1)
    title = f"mimika: {rig.head.name} head, every modelled Action Unit at full intensity"
    return contact_sheet(images, labels, columns=columns, title=title)
