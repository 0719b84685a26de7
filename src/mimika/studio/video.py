"""MP4 export for the studio: the headless renderer + the MP4 writer (when both are installed)."""

from __future__ import annotations

import importlib.util
import logging
from pathlib import Path
from typing import Any

import numpy as np

log = logging.getLogger(__name__)

#: longest clip the studio renders in one request (seconds)
MAX_SECONDS = 60.0


def available() -> str | None:
    """``None`` if MP4 export works here, else the reason it does not."""
    for mod in ("mimika.render.video", "av", "moderngl"):
        try:
            if importlib.util.find_spec(mod) is None:
                return f"MP4 export isn't available: {mod} is not installed"
        except (ImportError, ValueError):
            return f"MP4 export isn't available: {mod} cannot be imported"
    return None


def render_mp4(rig: Any, track: Any, path: str | Path, *, audio: np.ndarray | None = None,
               sr: int | None = None, size: tuple[int, int] = (640, 480),
               view: str = "front", look: str = "plain", progress: Any = None) -> Path:
    """Render ``track`` on ``rig``'s head into an H.264/AAC MP4 at ``track.fps`` (atomic).

    ``look``: ``plain`` — mimika's renders (``mimika pose``); ``news`` — the newsreader's
    (skin shader, news studio lighting, set and desk), as ``mimika news`` draws it.
    ``progress(done, total)`` after every frame; an exception it raises stops the render."""
    from mimika.errors import ParameterError

    if track.duration > MAX_SECONDS:
        raise ParameterError(f"the clip is {track.duration:.1f} s; the studio renders at most "
                             f"{MAX_SECONDS:.0f} s (use 'mimika render' for longer ones)")
    if look == "news":
        import contextlib

        from mimika.newsreader.pipeline import render_frames
        from mimika.render.video import VideoWriter

        w, h = (int(x) // 2 * 2 for x in size)
        keep = [c for c in track.channels if c in set(rig.supported)]
        track = track.with_channels(keep)
        frames = render_frames(rig, track, size=(w, h), view=view, workers=1)
        with VideoWriter(path, fps=track.fps, size=(w, h), audio=audio, sr=sr) as out, \
                contextlib.closing(frames):
            for i, img in enumerate(frames):
                out.write(img)
                if progress is not None:
                    progress(i + 1, track.n_frames)
    else:
        from mimika.render.video import write_track_video

        write_track_video(rig, track, path, audio=audio, sr=sr, size=size, view=view,
                          progress=progress)
    log.info("studio: wrote %s (%d frames, %s look)", path, track.n_frames, look)
    return Path(path)
