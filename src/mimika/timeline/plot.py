"""AU curves over time as a PNG (matplotlib, Agg backend, imported only here)."""

from __future__ import annotations

import io
import os
from collections.abc import Sequence
from pathlib import Path

import numpy as np

from mimika.errors import ParameterError
from mimika.facs import AU_CATALOGUE, parse_au
from mimika.io.atomic import atomic_write
from mimika.tracks import AUTrack

__all__ = ["plot_track"]

_GROUPS = ("upper face", "lower face linear", "lower face orbital", "misc", "head", "eyes")


def plot_track(track: AUTrack, path: str | os.PathLike, *, aus: Sequence[str] | None = None,
               title: str | None = None, size: tuple[float, float] = (10.0, 6.0)) -> Path:
    """Plot AU intensities (y, 0–1) against time (x, seconds) to a PNG, atomically.

    One subplot per FACS group when more than 6 channels are drawn; legend entries name the AU
    (``AU12 Lip Corner Puller``). ``aus`` selects channels (all non-zero ones by default).
    """
    import matplotlib

    matplotlib.use("Agg", force=False)
    import matplotlib.pyplot as plt

    if aus:
        chans = [parse_au(a) for a in aus]
        missing = [c for c in chans if c not in track.channels]
        if missing:
            raise ParameterError(f"the track has no {', '.join(missing)} (it has "
                                 f"{', '.join(track.channels) or 'no channels'})")
    else:
        chans = [c for c in track.channels if np.any(track[c] > 1e-4)] or list(track.channels)
    if not chans:
        raise ParameterError("nothing to plot: the track has no AU channels")
    groups: dict[str, list[str]] = {}
    for c in chans:
        g = AU_CATALOGUE[c[:4]].group if len(chans) > 6 else "AUs"
        groups.setdefault(g, []).append(c)
    order = sorted(groups, key=lambda g: _GROUPS.index(g) if g in _GROUPS else -1)
    fig, axes = plt.subplots(len(order), 1, figsize=size, sharex=True, squeeze=False)
    t = track.times
    for ax, g in zip(axes[:, 0], order, strict=True):
        for c in groups[g]:
            ax.plot(t, track[c], label=f"{c} {AU_CATALOGUE[c[:4]].name}", lw=1.4)
        ax.set_ylim(-0.02, 1.02)
        ax.set_ylabel("intensity")
        if len(order) > 1:
            ax.set_title(g, fontsize=9, loc="left")
        ax.grid(alpha=0.3)
        ax.legend(fontsize=7, loc="upper right", ncol=2 if len(groups[g]) > 5 else 1)
    axes[-1, 0].set_xlabel("time (s)")
    fig.suptitle(title or f"{track.meta.get('source', 'AU track')} — {track.fps:g} fps")
    fig.tight_layout()
    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=100)
    plt.close(fig)
    return atomic_write(path, buf.getvalue())
