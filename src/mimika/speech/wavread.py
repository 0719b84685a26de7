"""WAV files read chunk by chunk and streamed: any header a file may carry is one
:class:`~mimika.errors.DataError`, and memory is the mono result plus one block.

The RIFF chunks are walked by their sizes (no recursion: a LIST nested 10 000 deep is one
skipped chunk), at most :data:`MAX_CHUNKS` of them; ``fmt `` must say PCM (8, 16, 24, 32 bit)
or IEEE float (32, 64 bit), directly or through WAVE_FORMAT_EXTENSIBLE; duration, rate and
channels are checked against :mod:`mimika.limits` before a sample is read; a ``data`` chunk
longer than the file is read as far as the file goes.
"""

from __future__ import annotations

import os
import struct
from pathlib import Path

import numpy as np

from mimika import limits
from mimika.errors import DataError

#: chunks looked at before ``fmt `` and ``data`` must have been found
MAX_CHUNKS = 1000
#: frames converted at once
BLOCK = 1 << 16
_PCM, _FLOAT, _EXTENSIBLE = 1, 3, 0xFFFE
_CONVERT = "convert it, e.g. 'ffmpeg -i IN -ac 1 -c:a pcm_s16le OUT.wav'"


class Unsupported(DataError):
    """A WAV file in a sample format this reader leaves to FFmpeg (A-law, ADPCM, RF64 …)."""


def _chunks(fh, size: int, name: str) -> tuple[bytes, int, int, int]:
    """(fmt body, data offset, bytes of data the header declares, bytes of it the file
    holds) of an open RIFF WAVE file of ``size`` bytes. A data size of 0 or 0xFFFFFFFF (a WAV
    written to a pipe) declares the rest of the file."""
    fmt: bytes | None = None
    data: tuple[int, int, int] | None = None
    pos = 12
    for _ in range(MAX_CHUNKS):
        fh.seek(pos)
        head = fh.read(8)
        if len(head) < 8:
            break
        cid, n = head[:4], struct.unpack("<I", head[4:])[0]
        if cid == b"fmt " and fmt is None:
            fmt = fh.read(min(n, 64))
        elif cid == b"data" and data is None:
            held = max(0, size - pos - 8)
            data = (pos + 8, held if n in (0, 0xFFFFFFFF) else n, min(n, held) or held)
        if fmt is not None and data is not None:
            return fmt, *data
        pos += 8 + n + (n & 1)
    what = "format ('fmt ')" if fmt is None else "'data'"
    raise DataError(f"{name}: no {what} chunk in the WAV file (a damaged header?); {_CONVERT}")


def _format(fmt: bytes, name: str) -> tuple[int, int, int, int]:
    """(sample kind, channels, rate, bytes per sample) from a ``fmt `` chunk."""
    if len(fmt) < 16:
        raise DataError(f"{name}: the WAV format chunk is {len(fmt)} bytes, not 16; {_CONVERT}")
    tag, channels, rate, _, _, bits = struct.unpack("<HHIIHH", fmt[:16])
    if tag == _EXTENSIBLE and len(fmt) >= 26:
        tag = struct.unpack("<H", fmt[24:26])[0]  # the sub-format GUID's first two bytes
    width = bits // 8
    ok = {_PCM: (1, 2, 3, 4), _FLOAT: (4, 8)}
    if tag not in ok or bits % 8 or width not in ok[tag]:
        kind = {_PCM: "PCM", _FLOAT: "float"}.get(tag, f"format {tag}")
        raise Unsupported(f"{name}: {kind} WAV with {bits}-bit samples cannot be read (PCM 8/"
                          f"16/24/32-bit or float 32/64-bit); {_CONVERT}")
    if channels < 1:
        raise DataError(f"{name}: the WAV header declares no channels; {_CONVERT}")
    return tag, channels, rate, width


def _samples(raw: bytes, tag: int, width: int) -> np.ndarray:
    """Float32 samples of little-endian ``raw``."""
    if tag == _FLOAT:
        return np.frombuffer(raw, f"<f{width}").astype(np.float32)
    if width == 1:
        return (np.frombuffer(raw, np.uint8).astype(np.float32) - 128.0) / 128.0
    if width == 3:
        b = np.frombuffer(raw, np.uint8).reshape(-1, 3).astype(np.int32)
        v = b[:, 0] | (b[:, 1] << 8) | (b[:, 2] << 16)
        v = np.where(v >= 1 << 23, v - (1 << 24), v)
        return v.astype(np.float32) / float(1 << 23)
    return np.frombuffer(raw, f"<i{width}").astype(np.float32) / float(1 << (8 * width - 1))


def read_wav(path: str | os.PathLike) -> tuple[np.ndarray, int]:
    """Read a PCM or float WAV (any channels, mixed to mono), block by block.

    Returns ``(audio, sr)``: float32 shape (n_samples,) and the rate in Hz.
    """
    p = Path(path)
    name = repr(str(p))
    if not p.is_file():
        raise DataError(f"audio file {name} does not exist")
    try:
        with open(p, "rb") as fh:
            size = os.fstat(fh.fileno()).st_size
            riff = fh.read(12)
            if riff[:4] in (b"RF64", b"BW64") and riff[8:12] == b"WAVE":
                raise Unsupported(f"{name}: an RF64 WAV; {_CONVERT}")
            if len(riff) < 12 or riff[:4] != b"RIFF" or riff[8:12] != b"WAVE":
                raise DataError(f"cannot read {name} as PCM WAV (no RIFF/WAVE header); "
                                f"{_CONVERT}")
            fmt, at, declared, length = _chunks(fh, size, name)
            tag, channels, sr, width = _format(fmt, name)
            frame = channels * width
            limits.check_recording(declared // frame / max(sr, 1), sr, channels, name)
            n = length // frame
            out = np.empty(n, np.float32)
            fh.seek(at)
            done = 0
            while done < n:
                raw = fh.read(min(BLOCK, n - done) * frame)
                k = len(raw) // frame
                if k == 0:
                    break
                with np.errstate(over="ignore", invalid="ignore"):  # refused below
                    x = _samples(raw[:k * frame], tag, width)
                    out[done:done + k] = x.reshape(k, channels).mean(axis=1)
                done += k
    except OSError as e:
        raise DataError(f"cannot read {name}: {e.strerror or e}") from None
    if done == 0:
        raise DataError(f"audio file {name} holds no samples")
    out = out[:done]
    if not np.all(np.isfinite(out)):
        raise DataError(f"{name}: the float WAV holds NaN or infinite samples; {_CONVERT}")
    return out, int(sr)
