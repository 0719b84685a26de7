"""PNG output for transitions: AU curves (matplotlib) over a strip of rendered frames."""

from __future__ import annotations

import io
import logging
import os

import numpy as np

from mimika.errors import MimikaError
from mimika.tracks import AUTrack

log = logging.getLogger(__name__)

__all__ = ["curves_image", "transition_png"]


def curves_image(track: AUTrack, *, title: str = "", width: int = 900,
                 min_peak: float = 0.05) -> np.ndarray:
    """Plot the channels of ``track`` that reach ``min_peak``; returns (H, W, 3) uint8."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from PIL import Image

    fig, ax = plt.subplots(figsize=(width / 100, 3.2), dpi=100)
    t = track.times
    for j, c in enumerate(track.channels):
        if np.max(track.values[:, j]) >= min_peak:
            ax.plot(t, track.values[:, j], label=c, lw=1.6)
    ax.set_xlabel("time (s)")
    ax.set_ylabel("intensity")
    ax.set_ylim(-0.02, 1.02)
    ax.set_title(title, fontsize=10)
    ax.legend(ncol=6, fontsize=7, loc="upper center")
    ax.grid(alpha=0.3)
    fig.tight_layout()
    buf = io.BytesIO()
    fig.savefig(buf, format="png")
    plt.close(fig)
    buf.seek(0)
    return np.asarray(Image.open(buf).convert("RGB"))


def transition_png(track: AUTrack, path: str | os.PathLike, *, title: str = "",
                   frames: int = 6, head: str = "builtin", tile: tuple[int, int] = (200, 200)):
    """Write the curves plot, above a strip of ``frames`` rendered frames (if rendering is
    available; otherwise the plot alone, with a logged warning)."""
    from PIL import Image

    from mimika.render import save_png

    plot = curves_image(track, title=title)
    parts = [plot]
    if frames > 0:
        try:
            from mimika.face.heads import load_head
            from mimika.render import Renderer, contact_sheet

            _, rig = load_head(head)
            idx = np.linspace(0, track.n_frames - 1, frames).round().astype(int)
            imgs, labels = [], []
            with Renderer(rig.head, size=tile) as r:
                for i in idx:
                    aus = rig.check({c: float(v) for c, v in track.frame(int(i)).items()
                                     if c in set(rig.supported) and v > 1e-4})
                    imgs.append(r.render(rig.deform(aus), view="front", aus=aus))
                    labels.append(f"{i / track.fps:.2f} s")
            strip = contact_sheet(imgs, labels, columns=frames)
            w = plot.shape[1]
            s = Image.fromarray(strip)
            s = s.resize((w, round(s.height * w / s.width)))
            parts.append(np.asarray(s))
        except (MimikaError, ImportError, AttributeError) as e:
            log.warning("no rendered strip (%s); writing the plot only", e)
    img = np.concatenate(parts, axis=0) if len(parts) > 1 else parts[0]
    return save_png(img, path)
