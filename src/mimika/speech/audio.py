"""Audio helpers: WAV I/O with the stdlib ``wave`` module, validation, resampling, envelopes."""

from __future__ import annotations

import importlib.util
import io
import os
import wave
from pathlib import Path

import numpy as np

from mimika import limits
from mimika.errors import DataError, ParameterError
from mimika.speech.utterance import _write_atomic


def valid_audio(audio: np.ndarray, *, sr: float) -> np.ndarray:
    """Return ``audio`` as float32 mono, shape (n_samples,); raise ``ParameterError`` when it is
    not 1-D, not finite or ``sr`` is not positive."""
    a = np.asarray(audio)
    if not np.issubdtype(a.dtype, np.number):
        raise ParameterError(f"audio must be numeric, got dtype {a.dtype}")
    if a.ndim != 1:
        raise ParameterError(f"audio must be mono, shape (n_samples,), got shape {a.shape}")
    if np.issubdtype(a.dtype, np.integer):
        a = a.astype(np.float32) / float(np.iinfo(a.dtype).max + 1)
    a = a.astype(np.float32, copy=False)
    if not np.all(np.isfinite(a)):
        raise ParameterError("audio contains NaN or infinity")
    if not (np.isfinite(sr) and sr > 0):
        raise ParameterError(f"sr={sr!r} must be > 0 Hz")
    return a


def resample(audio: np.ndarray, *, orig_sr: int, target_sr: int) -> np.ndarray:
    """Polyphase resampling (scipy) of mono float audio from ``orig_sr`` to ``target_sr`` Hz."""
    from math import gcd

    from scipy.signal import resample_poly

    if orig_sr == target_sr:
        return np.asarray(audio, np.float32)
    g = gcd(int(orig_sr), int(target_sr))
    return resample_poly(audio, int(target_sr) // g, int(orig_sr) // g).astype(np.float32)


def write_wav(path: str | os.PathLike, audio: np.ndarray, *, sr: int) -> None:
    """Write mono float audio in [-1, 1] as 16-bit PCM WAV (atomically)."""
    a = valid_audio(audio, sr=sr)
    pcm = (np.clip(a, -1.0, 1.0) * 32767.0).round().astype("<i2")
    buf = io.BytesIO()
    with wave.open(buf, "wb") as w:
        w.setnchannels(1)
        w.setsampwidth(2)
        w.setframerate(int(sr))
        w.writeframes(pcm.tobytes())
    _write_atomic(path, buf.getvalue())


def read_wav(path: str | os.PathLike) -> tuple[np.ndarray, int]:
    """Read a PCM (8/16/24/32-bit) or float WAV, any channels mixed to mono, streamed
    (:mod:`mimika.speech.wavread`). Returns ``(audio, sr)``: float32 shape (n_samples,) in
    [-1, 1] and the rate in Hz."""
    from mimika.speech.wavread import read_wav as read

    return read(path)


def read_media(path: str | os.PathLike) -> tuple[np.ndarray, int]:
    """Read speech from a WAV file, or from any audio/video file FFmpeg decodes (MP3, M4A,
    FLAC, OGG, MP4 … through PyAV); mono float32 and the rate in Hz."""
    from mimika.speech.wavread import Unsupported

    p = Path(path)
    if p.suffix.lower() in (".wav", ".wave"):
        try:
            return read_wav(p)
        except Unsupported:  # A-law, ADPCM, RF64 …: FFmpeg's, when PyAV is there
            if importlib.util.find_spec("av") is None:
                raise
    if not p.is_file():
        raise DataError(f"audio file {str(p)!r} does not exist")
    try:
        import av
    except ImportError:
        raise DataError(f"reading {p.suffix} needs PyAV: pip install av (or convert to WAV: "
                        f"'ffmpeg -i {p.name} -ac 1 out.wav')") from None
    try:
        with av.open(str(p)) as c:
            if not c.streams.audio:
                raise DataError(f"{str(p)!r} has no audio stream")
            st = c.streams.audio[0]
            what = repr(str(p))
            if getattr(st, "codec_context", None) is None:
                raise DataError(f"{what}: its audio is in a format FFmpeg does not decode; "
                                "export it again as PCM WAV, FLAC or MP3")
            rate = int(st.rate or 0)
            secs = (float(st.duration * st.time_base) if st.duration and st.time_base
                    else (c.duration or 0) / 1e6)
            limits.check_recording(secs, rate, int(st.channels or 1), what)
            # streamed: mono, at most 48 kHz, and stopped at the limit whatever the header said
            sr = min(rate, 48_000)
            most = int(limits.current().max_recording * sr) + sr
            parts, n = [], 0
            rs, setup = None, None
            for fr in c.decode(st):
                if (fr.format.name, fr.layout.name, fr.sample_rate) != setup:
                    # a stream whose frames change rate or layout: a resampler for each run
                    parts += _flush(rs)
                    rs = av.AudioResampler(format="flt", layout="mono", rate=sr)
                    setup = (fr.format.name, fr.layout.name, fr.sample_rate)
                for f in rs.resample(fr):
                    parts.append(f.to_ndarray().reshape(-1))
                    n += parts[-1].size
                if n > most:
                    limits.check_recording(n / sr, sr, 1, what)
            parts += _flush(rs)
    except (av.error.FFmpegError, ValueError) as e:  # ValueError: frames PyAV cannot convert
        raise DataError(f"cannot decode {str(p)!r}: {e}; convert it, e.g. "
                        f"'ffmpeg -i {p.name} -ac 1 out.wav'") from None
    a = np.concatenate(parts).astype(np.float32) if parts else np.zeros(0, np.float32)
    if a.size == 0:
        raise DataError(f"audio file {str(p)!r} holds no samples")
    return a, sr


def _flush(rs) -> list[np.ndarray]:
    """What a PyAV resampler still holds (nothing without one)."""
    return [] if rs is None else [f.to_ndarray().reshape(-1) for f in rs.resample(None)]


def rms_envelope(audio: np.ndarray, *, sr: int, fps: float, n_frames: int | None = None
                 ) -> np.ndarray:
    """RMS of ``audio`` in a window of ``1/fps`` s centred on each frame time; shape (n_frames,)."""
    a = valid_audio(audio, sr=sr)
    n = n_frames if n_frames is not None else int(np.ceil(len(a) / sr * fps))
    half = max(1, int(sr / fps / 2))
    c = np.concatenate([[0.0], np.cumsum(a.astype(np.float64) ** 2)])
    centres = (np.arange(n) / fps * sr).astype(int)
    lo = np.clip(centres - half, 0, len(a))
    hi = np.clip(centres + half, 0, len(a))
    e = (c[hi] - c[lo]) / np.maximum(hi - lo, 1)
    return np.sqrt(e).astype(np.float32)
