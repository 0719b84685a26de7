"""MP4 writing (H.264 video + AAC audio) through PyAV (FFmpeg), atomically.

:class:`VideoWriter` encodes RGB frames (yuv420p, even sizes) at a fixed frame rate, muxes mono
float audio as AAC, and writes to a temporary file beside the target that is renamed over it
only when everything succeeded — an interrupted or failed render leaves nothing half-written.
Encoding can run in a background thread (``threaded=True``) so that rendering and encoding
overlap.
"""

from __future__ import annotations

import contextlib
import functools
import logging
import os
import queue
import threading
import time
import unicodedata
from collections.abc import Callable
from fractions import Fraction
from pathlib import Path
from typing import Any

import numpy as np

from mimika.errors import DataError, ParameterError, RenderError
from mimika.io.atomic import make_temp, sweep_stale

log = logging.getLogger(__name__)

_STOP = object()


def _import_av() -> Any:
    try:
        import av
    except ImportError as exc:
        raise RenderError(f"video output needs PyAV ({exc}); install it with: "
                          "pip install 'mimika[video]'") from exc
    return av


class VideoWriter:
    """Write an MP4 file frame by frame.

    Parameters
    ----------
    path : target ``.mp4`` path (written atomically on :meth:`close`)
    fps : frames per second (keyword-only), > 0
    size : (width, height) in pixels; both must be even (yuv420p)
    audio : optional mono audio, shape (n_samples,), float32 in [-1, 1]
    sr : sample rate of ``audio`` in Hz (keyword-only, required with audio)
    crf, preset : libx264 quality (0–51, lower is better) and speed preset
    threaded : encode in a background thread
    overlay : ``overlay(frame, t)`` → the frame to encode, given each frame and its time in
        seconds (e.g. a :class:`TitleStrap`); it runs in the encoding thread

    Use as a context manager: leaving the block normally finishes the file; an exception
    discards it.
    """

    def __init__(self, path: str | os.PathLike, *, fps: float, size: tuple[int, int],
                 audio: np.ndarray | None = None, sr: int | None = None, crf: int = 23,
                 preset: str = "veryfast", threaded: bool = True,
                 overlay: Callable[[np.ndarray, float], np.ndarray] | None = None) -> None:
        av = _import_av()
        w, h = (int(s) for s in size)
        if w % 2 or h % 2 or w < 2 or h < 2:
            raise ParameterError(f"size={w}x{h}: H.264 (yuv420p) needs even width and height")
        if not (fps > 0):
            raise ParameterError(f"fps={fps!r} must be > 0")
        if not 0 <= int(crf) <= 51:
            raise ParameterError(f"crf={crf!r} must be in 0..51")
        if audio is not None and not sr:
            raise ParameterError("audio needs its sample rate sr")
        self.path = Path(path)
        self.size = (w, h)
        self.overlay = overlay
        self.fps = Fraction(fps).limit_denominator(1001)
        self.n_frames = 0
        #: seconds spent encoding (in the worker thread when threaded)
        self.encode_seconds = 0.0
        parent = self.path.parent if str(self.path.parent) else Path(".")
        try:
            sweep_stale(self.path)  # temp files of renders that were killed
            fd, tmp = make_temp(parent / self.path.name, suffix=".mp4")
            os.close(fd)
        except OSError as e:
            raise DataError(f"cannot write {str(self.path)!r}: {e.strerror or e}") from None
        self._tmp = tmp
        try:
            self._c = av.open(str(self._tmp), mode="w", format="mp4")
            vs = self._c.add_stream("libx264", rate=self.fps)
            vs.width, vs.height = w, h
            vs.pix_fmt = "yuv420p"
            # one encoder thread: frames come slower than x264 encodes them on one core
            # (rendering is always the bottleneck), and frame threads cost ~10 % more CPU;
            # CAVLC instead of CABAC: 15-20 % less encoding CPU for ~11 % more bytes at the
            # same quality (a 720p bulletin: 1.3 → 1.5 MB); with the default preset, the
            # cheapest sub-pixel search and no partition search: a quarter less again at the
            # same PSNR for 40 % more bytes (the bulletin ≈ 2 MB; bench/bench_encode.py)
            params = "cabac=0" + (":subme=1:partitions=none" if preset == "veryfast" else "")
            vs.options = {"crf": str(int(crf)), "preset": preset, "threads": "1",
                          "x264-params": params}
            vs.codec_context.time_base = Fraction(1, 1) / self.fps
            self._vs = vs
            self._as = None
            self._audio = None
            if audio is not None:
                a = np.ascontiguousarray(audio, np.float32).reshape(-1)
                st = self._c.add_stream("aac", rate=int(sr))
                st.layout = "mono"
                st.codec_context.time_base = Fraction(1, int(sr))
                self._as, self._audio, self._sr, self._apos = st, a, int(sr), 0
        except Exception:
            self._discard()
            raise
        self._err: BaseException | None = None
        self._q: queue.Queue | None = None
        self._thread: threading.Thread | None = None
        if threaded:
            self._q = queue.Queue(maxsize=8)
            self._thread = threading.Thread(target=self._worker, name="mimika-video",
                                            daemon=True)
            self._thread.start()

    # ---------------------------------------------------------------- encoding
    def _encode_audio_until(self, t: float | None) -> None:
        if self._as is None:
            return
        av = _import_av()
        end = len(self._audio) if t is None else min(len(self._audio), int(t * self._sr))
        step = self._as.codec_context.frame_size or 1024
        while self._apos < end and (t is None or end - self._apos >= step):
            chunk = self._audio[self._apos: self._apos + step]
            fr = av.AudioFrame.from_ndarray(chunk[None, :], format="fltp", layout="mono")
            fr.sample_rate = self._sr
            fr.pts = self._apos
            fr.time_base = Fraction(1, self._sr)
            self._apos += len(chunk)
            for pkt in self._as.encode(fr):
                self._c.mux(pkt)

    def _encode(self, rgb: np.ndarray, index: int) -> None:
        av = _import_av()
        t0 = time.perf_counter()
        if self.overlay is not None:
            rgb = self.overlay(rgb, index / float(self.fps))
        # RGB → YUV 4:2:0 with point-sampled chroma: a third cheaper than swscale's default
        # filter and as close to the image (bench/bench_encode.py)
        fr = av.VideoFrame.from_ndarray(rgb, format="rgb24").reformat(
            format="yuv420p", interpolation="POINT")
        fr.pts = index
        fr.time_base = Fraction(1, 1) / self.fps
        for pkt in self._vs.encode(fr):
            self._c.mux(pkt)
        self._encode_audio_until((index + 1) / float(self.fps))
        self.encode_seconds += time.perf_counter() - t0

    def _worker(self) -> None:
        assert self._q is not None
        while True:
            item = self._q.get()
            if item is _STOP:
                return
            if self._err is not None:
                continue
            try:
                self._encode(*item)
            except BaseException as e:  # reported on the next write / close
                self._err = e

    def write(self, frame: np.ndarray) -> None:
        """Append one frame, shape (height, width, 3) uint8 RGB, top row first."""
        a = np.asarray(frame)
        if a.shape != (self.size[1], self.size[0], 3) or a.dtype != np.uint8:
            raise ParameterError(f"frame has shape {a.shape} {a.dtype}, expected "
                                 f"({self.size[1]}, {self.size[0]}, 3) uint8")
        if self._err is not None:
            raise RenderError(f"video encoding failed: {self._err}") from self._err
        if self._q is not None:
            self._q.put((np.ascontiguousarray(a), self.n_frames))
        else:
            self._encode(a, self.n_frames)
        self.n_frames += 1

    def _join(self, *, abort: bool = False) -> None:
        """Let the encoder thread finish (``abort``: skip what is queued) and wait for it —
        before the container is closed, which must not happen while it encodes."""
        if self._thread is None:
            return
        assert self._q is not None
        if abort and self._err is None:
            self._err = RenderError("the video was abandoned")
        sent = False
        while self._thread.is_alive():  # polling: SIGTERM can arrive meanwhile
            if not sent:
                with contextlib.suppress(queue.Full):
                    self._q.put(_STOP, timeout=0.1)
                    sent = True
            self._thread.join(0.1)

    def close(self) -> Path:
        """Flush the encoders, finish the file and move it to :attr:`path`; returns it."""
        try:
            self._join()
            if self._err is not None:
                raise RenderError(f"video encoding failed: {self._err}") from self._err
            for pkt in self._vs.encode(None):
                self._c.mux(pkt)
            if self._as is not None:
                self._encode_audio_until(None)
                for pkt in self._as.encode(None):
                    self._c.mux(pkt)
            self._c.close()
            with open(self._tmp, "rb+") as f:
                os.fsync(f.fileno())
            umask = os.umask(0)
            os.umask(umask)
            os.chmod(self._tmp, 0o666 & ~umask)  # like a plain open(); mkstemp makes it 0600
            os.replace(self._tmp, self.path)
        except OSError as e:
            self.abort()
            raise DataError(f"cannot write {str(self.path)!r}: {e.strerror or e}") from None
        except BaseException:  # also SIGTERM / Ctrl-C while waiting for the encoder
            self.abort()
            raise
        log.info("wrote %s: %d frames at %s fps", self.path, self.n_frames, self.fps)
        return self.path

    def abort(self) -> None:
        """Stop and delete the temporary file; the target is left untouched."""
        self._join(abort=True)
        self._discard()

    def _discard(self) -> None:
        with contextlib.suppress(Exception):
            self._c.close()
        with contextlib.suppress(OSError):
            self._tmp.unlink()

    def __enter__(self) -> VideoWriter:
        return self

    def __exit__(self, exc_type, exc, tb) -> None:
        if exc_type is None:
            self.close()
        else:
            self.abort()


def write_track_video(rig: Any, track: Any, path: str | os.PathLike, *,
                      size: tuple[int, int] = (640, 480), view: str = "front", samples: int = 4,
                      audio: np.ndarray | None = None, sr: int | None = None,
                      progress: Callable[[int, int], None] | None = None) -> Path:
    """Render the AU ``track`` on ``rig``'s head into an H.264 (+ AAC with ``audio``) MP4 at
    ``track.fps``, written atomically. Channels the rig does not model are left out.
    ``progress(done, total)`` is called after every frame; an exception it raises stops the
    render and leaves no file."""
    from mimika.render import Renderer

    w, h = (int(s) // 2 * 2 for s in size)
    keep = [c for c in track.channels if c in set(rig.supported)]
    track = track.with_channels(keep)
    with Renderer(rig.head, size=(w, h), samples=samples) as r, \
            VideoWriter(path, fps=track.fps, size=(w, h), audio=audio, sr=sr) as out:
        for i, pos in enumerate(rig.deform_track(track)):
            out.write(r.render(pos, view=view, aus=track.frame(i)))
            if progress is not None:
                progress(i + 1, track.n_frames)
    return Path(path)


def probe(path: str | os.PathLike) -> dict[str, Any]:
    """Codec names, frame count and durations (s) of a video file, by decoding it with PyAV.

    Returns ``{"video_codec", "audio_codec", "width", "height", "fps", "n_frames",
    "video_duration", "audio_duration"}`` (audio entries None without audio).
    """
    av = _import_av()
    with av.open(str(path)) as c:
        vs = c.streams.video[0]
        ast = c.streams.audio[0] if c.streams.audio else None
        n = 0
        last_v = 0.0
        a_end = 0.0
        for frame in c.decode(*( [vs] + ([ast] if ast is not None else []))):
            if isinstance(frame, av.VideoFrame):
                n += 1
                last_v = float(frame.time)
            else:
                a_end = max(a_end, float(frame.time) + frame.samples / frame.sample_rate)
        fps = float(vs.average_rate or vs.base_rate)
        return {
            "video_codec": vs.codec_context.name,
            "audio_codec": ast.codec_context.name if ast is not None else None,
            "width": vs.width, "height": vs.height, "fps": fps, "n_frames": n,
            "video_duration": last_v + 1.0 / fps if n else 0.0,
            "audio_duration": a_end if ast is not None else None,
        }


@functools.cache
def _strap_style() -> dict[str, Any]:
    """``data/strap.json`` without its ``_doc``."""
    import json
    from importlib import resources

    text = resources.files("mimika.render").joinpath("data/strap.json").read_text("utf-8")
    return {k: v for k, v in json.loads(text).items() if not k.startswith("_")}


def _strap_font(name: str, px: int) -> Any:
    from importlib import resources

    from PIL import ImageFont

    with resources.as_file(resources.files("mimika.render").joinpath(f"data/fonts/{name}")) as f:
        return ImageFont.truetype(str(f), max(int(px), 6))


def _missing_glyphs(font: Any, text: str) -> list[str]:
    """Characters of ``text`` that ``font`` draws as its 'missing glyph' box."""
    def drawn(c: str) -> tuple:
        m = font.getmask(c)
        return m.size, bytes(m)

    box = drawn("\uffff")
    return sorted({c for c in text if not c.isspace() and drawn(c) == box})


def split_title(title: str) -> tuple[str, str]:
    """``"Amara Okafor — News at Nine"`` → (name, programme); no separator: (title, "")."""
    for sep in (" — ", " – ", " | ", " - "):
        if sep in title:
            name, _, line = title.partition(sep)
            return name.strip(), line.strip()
    return title.strip(), ""


def check_title(title: str) -> str:
    """``title`` without surrounding spaces, or a ParameterError: empty, longer than the
    strap takes, control characters, or characters its fonts cannot draw."""
    st = _strap_style()
    t = str(title).strip()
    if not t:
        raise ParameterError("the title is empty; give a name, e.g. --title "
                             "'Amara Okafor — News at Nine'")
    if len(t) > st["max_chars"]:
        raise ParameterError(f"the title has {len(t)} characters; a name strap takes at most "
                             f"{st['max_chars']}")
    bad = sorted({f"U+{ord(c):04X}" for c in t if unicodedata.category(c)[0] == "C"})
    if bad:
        raise ParameterError(f"the title contains control characters ({', '.join(bad)}); "
                             "give one line of text")
    name, line = split_title(t)
    for text, key in ((name, "name_font"), (line, "line_font")):
        miss = _missing_glyphs(_strap_font(st[key], 32), text)
        if miss:
            raise ParameterError(f"the title's font ({st[key].removesuffix('.ttf')}) cannot "
                                 f"draw {' '.join(repr(c) for c in miss[:5])}")
    return t


class TitleStrap:
    """A lower-third name strap over video frames: a dark bar with the name and a light bar
    with the programme below it, an accent stripe on the left (``data/strap.json``). Call it
    with a frame (H, W, 3) uint8 and its time (s): the frame is returned with the strap at
    that time's opacity (it fades in and out, see the style file)."""

    def __init__(self, title: str, size: tuple[int, int]) -> None:
        from PIL import Image, ImageDraw

        st = _strap_style()
        self.style = st
        self.title = check_title(title)
        name, line = split_title(self.title)
        w, h = (int(x) for x in size)
        # every edge on an even pixel: H.264's 4:2:0 colour is one sample per 2×2 pixels, and
        # an edge inside a pair smears the accent's orange into a grey or brown line
        even = lambda v: max(2 * round(v / 2), 2)  # noqa: E731
        px = lambda k: even(st[k] * h)  # noqa: E731
        x0, pad, accent = px("left"), px("pad"), px("accent_width")
        room = w - 2 * x0 - accent - 2 * pad
        rows = [(name, st["name_font"], st["name_size"], st["name_bar"], st["name_color"])]
        if line:
            rows.append((line, st["line_font"], st["line_size"], st["line_bar"],
                         st["line_color"]))
        fitted = []
        for text, font_name, size_k, bar, ink in rows:
            for scale in np.linspace(1.0, 0.7, 7):
                font = _strap_font(font_name, size_k * h * scale)
                if font.getlength(text) <= room:
                    break
            else:
                raise ParameterError(f"the title {self.title!r} is too long for a {w}x{h} "
                                     "video; shorten it or choose a larger --size")
            fitted.append((text, font, bar, ink))
        width = even(max(max(int(f.getlength(t)) for t, f, _, _ in fitted) + 2 * pad,
                         px("min_width") - accent) + 1)
        heights = [even(f.size * 1.15 + pad) for _, f, _, _ in fitted]
        total = sum(heights)
        rgb = np.zeros((total, accent + width, 3), np.float32)
        alpha = np.zeros((total, accent + width), np.float32)
        y = 0
        for (text, font, bar, ink), bh in zip(fitted, heights, strict=True):
            rgb[y:y + bh, accent:] = bar[:3]
            alpha[y:y + bh, accent:] = bar[3]
            mask = Image.new("L", (width, bh))
            ImageDraw.Draw(mask).text((pad, bh / 2), text, fill=255, font=font, anchor="lm")
            m = np.asarray(mask, np.float32)[:, :, None] / 255.0
            rgb[y:y + bh, accent:] = rgb[y:y + bh, accent:] * (1 - m) + np.asarray(ink) * m
            alpha[y:y + bh, accent:] = np.maximum(alpha[y:y + bh, accent:], m[:, :, 0])
            y += bh
        rgb[:, :accent] = st["accent"][:3]
        alpha[:, :accent] = st["accent"][3]
        top = min(px("top"), h - total - h % 2)
        #: the strap's box in the frame: (x0, y0, x1, y1) pixels
        self.box = (x0, top, min(x0 + accent + width, w), top + total)
        cw, ch = self.box[2] - x0, total
        # premultiplied sRGB in 0..255
        self._alpha = alpha[:ch, :cw, None]
        self._color = (rgb[:ch, :cw] * 255.0) * self._alpha

    def opacity(self, t: float) -> float:
        """How opaque the strap is at ``t`` seconds (0 before it comes in and after it goes)."""
        st = self.style
        ramp_in = (t - st["in"]) / st["fade"]
        ramp_out = (st["out"] - t) / st["fade"]
        return float(np.clip(min(ramp_in, ramp_out), 0.0, 1.0))

    def __call__(self, frame: np.ndarray, t: float) -> np.ndarray:
        a = self.opacity(t)
        if a <= 0.0:
            return frame
        x0, y0, x1, y1 = self.box
        out = np.array(frame, copy=True)
        region = out[y0:y1, x0:x1].astype(np.float32)
        out[y0:y1, x0:x1] = np.clip(region * (1.0 - a * self._alpha) + a * self._color + 0.5,
                                    0, 255).astype(np.uint8)
        return out
