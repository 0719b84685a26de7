"""The central AU-track type: frames of AU intensities over time.

Every module that produces or consumes animation takes and returns an :class:`AUTrack`.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from mimika.errors import ParameterError
from mimika.facs import parse_au
from mimika.limits import check_fps, check_frames


def _readonly(a: np.ndarray) -> np.ndarray:
    a = np.ascontiguousarray(a, dtype=np.float32)
    a.setflags(write=False)
    return a


def valid_fps(fps: float) -> float:
    """Return ``fps`` as float or raise ``ParameterError`` if it is not a positive finite number
    (or over :attr:`mimika.limits.Limits.max_fps`)."""
    return check_fps(fps)


@dataclass(frozen=True)
class AUTrack:
    """AU intensities sampled at a fixed rate.

    Parameters
    ----------
    values : ndarray, shape (n_frames, n_channels), float32
        Intensities; AU channels are in [0, 1]. Stored read-only.
    channels : tuple of str
        Channel names, canonical AU codes (``AU01``, ``AU12L``); unique.
    fps : float
        Frames per second, > 0.
    meta : dict
        Free-form provenance (source file, text …); not used in computation.
    """

    values: np.ndarray
    channels: tuple[str, ...]
    fps: float
    meta: dict[str, Any] = field(default_factory=dict, compare=False)

    def __post_init__(self) -> None:
        v = np.asarray(self.values, dtype=np.float32)
        if v.ndim == 1 and len(self.channels) == 1:
            v = v[:, None]
        if v.ndim != 2:
            raise ParameterError(f"values must be 2-D (frames × channels), got shape {v.shape}")
        chans = tuple(parse_au(c) for c in self.channels)
        if len(set(chans)) != len(chans):
            dup = sorted({c for c in chans if chans.count(c) > 1})
            raise ParameterError(f"channels must be unique; repeated: {', '.join(dup)}")
        if v.shape[1] != len(chans):
            raise ParameterError(
                f"values has {v.shape[1]} columns but {len(chans)} channels are named"
            )
        if not np.all(np.isfinite(v)):
            raise ParameterError("values contain NaN or infinity")
        object.__setattr__(self, "values", _readonly(v))
        object.__setattr__(self, "channels", chans)
        object.__setattr__(self, "fps", valid_fps(self.fps))

    # -- construction -------------------------------------------------------------------------
    @classmethod
    def constant(cls, aus: Mapping[str, float], *, n_frames: int = 1, fps: float = 25.0):
        """A track holding ``aus`` for ``n_frames`` frames."""
        chans = tuple(aus)
        check_frames(n_frames, "the constant track")
        vals = np.tile(np.array([aus[c] for c in chans], dtype=np.float32), (n_frames, 1))
        return cls(vals.reshape(n_frames, len(chans)), chans, fps)

    @classmethod
    def from_frames(cls, frames: Sequence[Mapping[str, float]], *, fps: float):
        """Build a track from per-frame dicts; missing channels are 0."""
        chans: list[str] = []
        for f in frames:
            for c in f:
                pc = parse_au(c)
                if pc not in chans:
                    chans.append(pc)
        vals = np.zeros((len(frames), len(chans)), np.float32)
        for i, f in enumerate(frames):
            for c, x in f.items():
                vals[i, chans.index(parse_au(c))] = x
        return cls(vals, tuple(chans), fps)

    # -- access -------------------------------------------------------------------------------
    @property
    def n_frames(self) -> int:
        return self.values.shape[0]

    @property
    def duration(self) -> float:
        """Length in seconds (``n_frames / fps``)."""
        return self.n_frames / self.fps

    @property
    def times(self) -> np.ndarray:
        """Frame times in seconds, shape (n_frames,)."""
        return np.arange(self.n_frames) / self.fps

    def __getitem__(self, channel: str) -> np.ndarray:
        return self.values[:, self.channels.index(parse_au(channel))]

    def __len__(self) -> int:
        return self.n_frames

    def frame(self, i: int) -> dict[str, float]:
        """Frame ``i`` as ``{code: intensity}``."""
        return {c: float(x) for c, x in zip(self.channels, self.values[i], strict=True)}

    def with_channels(self, channels: Sequence[str]) -> AUTrack:
        """The same frames over ``channels`` (missing ones are 0, extra ones dropped)."""
        chans = tuple(parse_au(c) for c in channels)
        out = np.zeros((self.n_frames, len(chans)), np.float32)
        for j, c in enumerate(chans):
            if c in self.channels:
                out[:, j] = self.values[:, self.channels.index(c)]
        return AUTrack(out, chans, self.fps, dict(self.meta))

    def resample(self, *, fps: float) -> AUTrack:
        """Linear resampling to ``fps`` over the same duration."""
        return AUTrack(
            resample_values(self.values, src_fps=self.fps, dst_fps=fps),
            self.channels,
            fps,
            dict(self.meta),
        )

    def to_dataframe(self):
        """A pandas DataFrame indexed by time (requires pandas)."""
        import pandas as pd

        return pd.DataFrame(self.values, columns=list(self.channels), index=self.times).rename_axis(
            "time"
        )


def resample_values(values: np.ndarray, *, src_fps: float, dst_fps: float) -> np.ndarray:
    """Linearly resample frames (shape (T, K)) from ``src_fps`` to ``dst_fps``."""
    src_fps, dst_fps = valid_fps(src_fps), valid_fps(dst_fps)
    t_src = np.arange(values.shape[0]) / src_fps
    n_dst = check_frames(max(1, round(values.shape[0] * dst_fps / src_fps)),
                         f"resampling to {dst_fps:g} fps")
    t_dst = np.arange(n_dst) / dst_fps
    return np.stack(
        [np.interp(t_dst, t_src, values[:, k]) for k in range(values.shape[1])], axis=1
    ).astype(np.float32).reshape(n_dst, values.shape[1])
