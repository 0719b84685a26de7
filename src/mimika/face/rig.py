"""The rig interface: AU intensities in, deformed vertices per object out."""

from __future__ import annotations

from abc import ABC, abstractmethod
from collections.abc import Iterator, Mapping, Sequence

import numpy as np

from mimika.errors import ParameterError
from mimika.face.head import Head
from mimika.facs import AU_CATALOGUE, base_code, is_body, parse_au
from mimika.tracks import AUTrack

Positions = dict[str, np.ndarray]


class Rig(ABC):
    """Maps AU intensities to vertex positions of every object of :attr:`head`."""

    head: Head

    @property
    @abstractmethod
    def supported(self) -> tuple[str, ...]:
        """Canonical AU codes this rig animates (bilateral codes; L/R variants where sided)."""

    @abstractmethod
    def deform(self, aus: Mapping[str, float]) -> Positions:
        """Vertex positions per object name for one set of AU intensities in [0, 1]."""

    def check(self, aus: Mapping[str, float]) -> dict[str, float]:
        """Canonicalise codes and reject AUs this rig does not model or values outside [0, 1]."""
        out: dict[str, float] = {}
        sup = set(self.supported)
        for code, val in aus.items():
            c = parse_au(code)
            if c not in sup:
                if is_body(c):
                    raise ParameterError(f"{c} moves the body; the {self.head.name!r} head "
                                         "has none (characters do: run 'mimika characters')")
                name = AU_CATALOGUE[base_code(c)].name
                raise ParameterError(
                    f"{c} ({name}) is not modelled by the {self.head.name!r} head; "
                    f"it models: {', '.join(self.supported_bilateral)}"
                )
            v = float(val)
            if not 0.0 <= v <= 1.0:
                raise ParameterError(f"{c}={v:g} is outside [0, 1]")
            out[c] = v
        return out

    @property
    def supported_bilateral(self) -> tuple[str, ...]:
        """The supported AUs without their L/R variants (and without body channels)."""
        return tuple(c for c in self.supported if len(c) == 4)

    def deform_track(self, track: AUTrack) -> Iterator[Positions]:
        """Deformed positions for every frame of ``track``."""
        for i in range(track.n_frames):
            yield self.deform(track.frame(i))

    def deform_batch(self, values: np.ndarray, channels: Sequence[str]) -> dict[str, np.ndarray]:
        """Positions for many frames at once: ``values`` (T, K) → {object: (T, N, 3)}.

        Rigs override this with a vectorised version; this one loops over :meth:`deform`.
        """
        frames = [self.deform(dict(zip(channels, row, strict=True))) for row in values]
        return {o.name: np.stack([f[o.name] for f in frames]) for o in self.head.objects}


def split_sides(aus: Mapping[str, float]) -> dict[str, tuple[float, float]]:
    """``{"AU12": 1, "AU12L": .5}`` → ``{"AU12": (left, right)}`` (clipped sums per side)."""
    out: dict[str, list[float]] = {}
    for c, v in aus.items():
        lr = out.setdefault(base_code(c), [0.0, 0.0])
        side = c[4:]
        if side in ("", "L"):
            lr[0] += v
        if side in ("", "R"):
            lr[1] += v
    return {c: (min(lr[0], 1.0), min(lr[1], 1.0)) for c, lr in out.items()}
