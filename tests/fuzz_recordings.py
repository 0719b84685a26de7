"""Fuzz target for recordings (issue 27): small hostile audio files fed to what ``mimika
align`` does — :func:`~mimika.speech.audio.read_media`, then
:func:`~mimika.speech.alignment.align` on whatever decodes.

Cases start from a short espeak-ng rendition of a GRID-like sentence, written as PCM WAV of 8 to
32 bits (1 or 2 channels, 8–48 kHz) or encoded as FLAC, MP3, Ogg Opus or M4A (AAC). WAV headers
are rebuilt chunk by chunk with hostile fields — RIFF and chunk sizes, format tag, channels,
sample rate, byte rate, block align, bits, chunks missing, repeated, nested or out of order;
FLAC's STREAMINFO gets hostile rates, channels, bits and sample counts; any file may then be
truncated, have bytes flipped or inserted, or carry another format's suffix.
"""

from __future__ import annotations

import functools
import io
import random
import struct

import numpy as np

R = random.Random
TRANSCRIPT = "bin blue at f two now"
_RATES = [8000, 11025, 16000, 22050, 44100, 48000]
_SIZES = [0, 1, 2, 3, 7, 44, 1000, 65535, 0x7FFFFFFF, 0xFFFFFFFE, 0xFFFFFFFF]
_HOSTILE_RATES = [0, 1, 3999, 4000, 96000, 96001, 192000, 0x7FFFFFFF, 0xFFFFFFFF]
_SUFFIXES = [".wav", ".flac", ".mp3", ".ogg", ".m4a", ".aiff", ".mp4", ".WAV", ".wave"]


@functools.cache
def _speech() -> tuple[np.ndarray, int]:
    from mimika.speech.tts import synthesize

    u = synthesize(TRANSCRIPT, lang="en", engine="espeak")
    return u.audio, u.sr


@functools.cache
def _at(sr: int) -> np.ndarray:
    from mimika.speech.audio import resample

    a, src = _speech()
    return resample(a, orig_sr=src, target_sr=sr)


def _pcm(a: np.ndarray, channels: int, width: int) -> bytes:
    x = np.repeat(np.clip(a, -1, 1)[:, None], channels, axis=1).reshape(-1)
    if width == 1:
        return (x * 127 + 128).astype(np.uint8).tobytes()
    if width == 3:
        v = (x * 8388607).astype("<i4").view(np.uint8).reshape(-1, 4)[:, :3]
        return v.tobytes()
    return (x * (2 ** (8 * width - 1) - 1)).astype(f"<i{width}").tobytes()


def _chunk(cid: bytes, body: bytes, size: int | None = None) -> bytes:
    size = len(body) if size is None else size
    return cid + struct.pack("<I", size & 0xFFFFFFFF) + body + b"\0" * (len(body) % 2)


def _pick(r: R, good: int, hostile: list[int]) -> int:
    return good if r.random() > getattr(r, "mut", 0.2) else r.choice(hostile)


def gen_wav(r: R) -> bytes:
    """A WAV rebuilt chunk by chunk, each field hostile at the case's mutation rate."""
    sr, ch, width = r.choice(_RATES), r.choice([1, 1, 2]), r.choice([1, 2, 2, 3, 4])
    data = _pcm(_at(sr), ch, width)
    tag = _pick(r, 1, [0, 3, 2, 85, 0xFFFE, 0xFFFF])
    n_ch = _pick(r, ch, [0, 3, 17, 64, 0xFFFF])
    rate = _pick(r, sr, _HOSTILE_RATES)
    bits = _pick(r, 8 * width, [0, 1, 12, 64, 0xFFFF])
    align = _pick(r, ch * width, [0, 1, 0xFFFF])
    fmt = struct.pack("<HHIIHH", tag, n_ch, rate & 0xFFFFFFFF,
                      _pick(r, sr * ch * width, _SIZES) & 0xFFFFFFFF, align, bits)
    if r.random() < 0.1:
        fmt += struct.pack("<H", r.choice([0, 22, 0xFFFF])) + bytes(r.randint(0, 30))
    chunks = [_chunk(b"fmt ", fmt, _pick(r, len(fmt), [0, 14, 40, 0xFFFFFFFF])),
              _chunk(b"data", data, _pick(r, len(data), _SIZES))]
    if r.random() < 0.2:  # a LIST chunk, maybe nested deep
        body = b"INFO" + _chunk(b"ISFT", b"mimika\0")
        for _ in range(r.choice([1, 5, 500])):
            body = _chunk(b"LIST", b"INFO" + body)
        chunks.insert(r.randint(0, len(chunks)), body)
    if r.random() < 0.1:
        chunks.insert(r.randint(0, len(chunks)), _chunk(b"junk", bytes(5), r.choice(_SIZES)))
    k = r.random()
    if k < 0.05:
        chunks.reverse()  # data before fmt
    elif k < 0.1:
        chunks.pop(r.randrange(len(chunks)))
    elif k < 0.15:
        chunks.append(chunks[r.randrange(len(chunks))])
    body = b"WAVE" + b"".join(chunks)
    return b"RIFF" + struct.pack("<I", _pick(r, len(body), _SIZES)) + body


@functools.cache
def _encoded(kind: str, sr: int) -> bytes:
    import av

    fmt, codec, rate = {"flac": ("flac", "flac", sr), "mp3": ("mp3", "libmp3lame", sr),
                        "ogg": ("ogg", "libopus", 48000), "m4a": ("ipod", "aac", sr)}[kind]
    a = _at(rate)
    buf = io.BytesIO()
    with av.open(buf, "w", format=fmt) as c:
        st = c.add_stream(codec, rate=rate, layout="mono")
        frame = av.AudioFrame.from_ndarray((a * 32767).astype(np.int16)[None, :], format="s16",
                                           layout="mono")
        frame.sample_rate = rate
        for p in [*st.encode(frame), *st.encode(None)]:
            c.mux(p)
    return buf.getvalue()


def gen_encoded(r: R) -> tuple[str, bytes]:
    kind = r.choice(["flac", "flac", "mp3", "ogg", "m4a"])
    data = bytearray(_encoded(kind, r.choice([16000, 22050, 44100])))
    if kind == "flac" and len(data) > 42 and r.random() < 0.7:
        # STREAMINFO at byte 8: block sizes, frame sizes, then rate (20 bits), channels − 1
        # (3), bits − 1 (5) and total samples (36) packed into 8 bytes at offset 18
        v = int.from_bytes(data[18:26], "big")
        rate, chans, bits, total = v >> 44, (v >> 41) & 7, (v >> 36) & 31, v & (2 ** 36 - 1)
        rate = _pick(r, rate, [0, 1, 3999, 96001, 2 ** 20 - 1])
        chans = _pick(r, chans, [7, 3])
        bits = _pick(r, bits, [0, 31, 2])
        total = _pick(r, total, [0, 1, 2 ** 36 - 1, 7200 * 16000])
        v = (rate << 44) | (chans << 41) | (bits << 36) | total
        data[18:26] = v.to_bytes(8, "big")
        if r.random() < 0.2:  # the metadata block's length
            data[5:8] = r.choice([0, 1, 2 ** 24 - 1]).to_bytes(3, "big")
    return "." + kind, bytes(data)


def damage(r: R, data: bytes) -> bytes:
    """Truncated, bytes flipped, bytes inserted — or left alone."""
    b = bytearray(data)
    k = r.random()
    if k < 0.15 and b:
        del b[r.randint(0, len(b) - 1):]
    elif k < 0.3 and b:
        for _ in range(r.randint(1, 20)):
            b[r.randrange(len(b))] = r.randrange(256)
    elif k < 0.35:
        at = r.randint(0, len(b))
        b[at:at] = bytes(r.randrange(256) for _ in range(r.randint(1, 64)))
    return bytes(b)


def gen_recording(r: R) -> tuple[str, bytes]:
    """(file suffix, bytes) of one hostile recording."""
    r.mut = r.choice([0.0, 0.05, 0.2, 0.5])  # type: ignore[attr-defined]
    suffix, data = (".wav", gen_wav(r)) if r.random() < 0.6 else gen_encoded(r)
    if r.random() < 0.05:
        suffix = r.choice(_SUFFIXES)
    return suffix, damage(r, data)


def run_recording(case: tuple[str, bytes]) -> None:
    from fuzzing import _scratch
    from mimika.speech.alignment import align
    from mimika.speech.audio import read_media

    suffix, data = case
    with _scratch() as d:
        p = d / f"rec{suffix}"
        p.write_bytes(data)
        audio, sr = read_media(p)
    align(audio, sr=sr, transcript=TRANSCRIPT, lang="en")
