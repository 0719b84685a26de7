"""Recordings are checked from their header before they are decoded: a broken or huge header
is one line with exit 2, in moments, never gigabytes of samples."""

from __future__ import annotations

import os
import struct
import subprocess
import sys

import numpy as np
import pytest


def _wav_header(path, *, sr: int, channels: int, seconds: float, data: bytes = b"") -> None:
    """A PCM16 WAV whose header declares ``seconds`` of audio but holds only ``data``."""
    size = int(seconds * sr) * channels * 2
    hdr = b"RIFF" + struct.pack("<I", 36 + size) + b"WAVEfmt " + struct.pack(
        "<IHHIIHH", 16, 1, channels, sr, sr * channels * 2, channels * 2, 16)
    path.write_bytes(hdr + b"data" + struct.pack("<I", size) + data)


def _align(path, env=None):
    return subprocess.run([sys.executable, "-m", "mimika", "align", str(path), "--transcript",
                           "bin blue at f two now", "-o", str(path.with_suffix(".json"))],
                          capture_output=True, text=True, timeout=120,
                          env={**os.environ, **(env or {})})


@pytest.mark.parametrize("kind, header, message", [
    ("1 Hz", dict(sr=1, channels=1, seconds=2000.0), "cannot hold speech"),
    ("2 hours", dict(sr=16000, channels=1, seconds=7200.0), "max_recording"),
    ("1 MHz", dict(sr=1_000_000, channels=1, seconds=1.0), "max_sample_rate"),
    ("64 channels", dict(sr=16000, channels=64, seconds=1.0), "max_channels"),
])
def test_a_hostile_wav_header_is_refused_before_decoding(tmp_path, kind, header, message):
    f = tmp_path / "rec.wav"
    _wav_header(f, **header, data=bytes(2000))
    r = _align(f)
    assert r.returncode == 2, (kind, r.stderr[-500:])
    lines = r.stderr.strip().splitlines()
    assert len(lines) == 1 and message in lines[0] and "rec.wav" in lines[0], r.stderr
    assert not f.with_suffix(".json").exists()


def test_a_long_compressed_recording_is_refused_from_its_header(tmp_path):
    av = pytest.importorskip("av")
    f = tmp_path / "rec.flac"
    with av.open(str(f), "w") as c:
        st = c.add_stream("flac", rate=16000, layout="mono")
        frame = av.AudioFrame.from_ndarray(np.zeros((1, 16000 * 3), np.int16), format="s16",
                                           layout="mono")
        frame.sample_rate = 16000
        for p in st.encode(frame):
            c.mux(p)
        for p in st.encode(None):
            c.mux(p)
    r = _align(f, env={"MIMIKA_MAX_RECORDING": "2"})
    assert r.returncode == 2, r.stderr[-500:]
    lines = r.stderr.strip().splitlines()
    assert len(lines) == 1 and "max_recording" in lines[0] and "MIMIKA_MAX_RECORDING" in lines[0]


# -- leftovers ------------------------------------------------------------------------------------
def test_a_killed_render_leaves_no_espeak_copy_in_the_temp_folder(tmp_path):
    import signal
    import time

    tmp, cache = tmp_path / "tmp", tmp_path / "cache"
    tmp.mkdir()
    env = {**os.environ, "TMPDIR": str(tmp), "MIMIKA_CACHE_DIR": str(cache)}
    say = [sys.executable, "-m", "mimika", "say", "Good evening.", "-o", str(tmp_path / "a.wav")]
    assert subprocess.run(say, env=env, capture_output=True, timeout=120).returncode == 0
    copies = list(cache.glob("espeak/*/libespeak*"))
    assert len(copies) == 1  # the one copy every run loads
    p = subprocess.Popen([sys.executable, "-m", "mimika", "news", "--example", "en", "--head",
                          "builtin", "-o", str(tmp_path / "n.mp4")], env=env,
                         stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    time.sleep(6)
    p.send_signal(signal.SIGKILL)
    p.wait(30)
    assert not list(tmp.glob("mimika-espeak-*"))
    assert list(cache.glob("espeak/*/libespeak*")) == copies
    assert subprocess.run(say, env=env, capture_output=True, timeout=120).returncode == 0
    assert not list(tmp.glob("mimika-espeak-*"))


# -- the WAV reader (streamed, chunk by chunk) -----------------------------------------------------
def _riff(*chunks: bytes) -> bytes:
    body = b"WAVE" + b"".join(chunks)
    return b"RIFF" + struct.pack("<I", len(body)) + body


def _ck(cid: bytes, body: bytes, size: int | None = None) -> bytes:
    return cid + struct.pack("<I", len(body) if size is None else size) + body + \
        b"\0" * (len(body) % 2)


def _fmt(tag=1, ch=1, sr=16000, bits=16) -> bytes:
    return _ck(b"fmt ", struct.pack("<HHIIHH", tag, ch, sr, sr * ch * bits // 8, ch * bits // 8,
                                    bits))


def test_wav_chunks_nested_deep_padded_or_piped_read_like_plain_ones(tmp_path):
    from mimika.speech.audio import read_wav

    tone = (np.sin(np.arange(1600) * 0.3) * 0.5).astype(np.float32)
    pcm = (tone * 32767).astype("<i2").tobytes()
    deep = b"INFO"
    for _ in range(5000):  # a LIST inside a LIST … 5 000 deep: one chunk to skip
        deep = _ck(b"LIST", b"INFO" + deep)
    stereo24 = np.repeat((tone * 8388607).astype("<i4")[:, None], 2, axis=1)
    cases = {
        "nested": _riff(deep, _fmt(), _ck(b"data", pcm)),
        "data first": _riff(_ck(b"data", pcm), _ck(b"junk", b"x" * 3), _fmt()),
        "piped": _riff(_fmt(), _ck(b"data", pcm, 0xFFFFFFFF)),
        "float": _riff(_fmt(tag=3, bits=32), _ck(b"data", tone.astype("<f4").tobytes())),
        "24-bit stereo": _riff(_fmt(ch=2, bits=24), _ck(b"data", stereo24.astype("<i4").view(
            np.uint8).reshape(-1, 4)[:, :3].tobytes())),
    }
    for kind, data in cases.items():
        f = tmp_path / "rec.wav"
        f.write_bytes(data)
        a, sr = read_wav(f)
        assert sr == 16000 and len(a) == 1600, kind
        assert np.max(np.abs(a - tone)) < 1e-3, kind


@pytest.mark.parametrize("kind, data, message", [
    ("no fmt", _riff(_ck(b"data", bytes(3200))), "no format ('fmt ') chunk"),
    ("no data", _riff(_fmt()), "no 'data' chunk"),
    ("unknown format", _riff(_fmt(tag=0x3333), _ck(b"data", bytes(3200))),
     "a format FFmpeg does not decode"),
    ("NaN", _riff(_fmt(tag=3, bits=32), _ck(b"data", np.full(1600, np.nan, "<f4").tobytes())),
     "NaN"),
    ("1e300", _riff(_fmt(tag=3, bits=64), _ck(b"data", np.full(1600, 1e300, "<f8").tobytes())),
     "infinite"),
    ("no channels", _riff(_fmt(ch=0), _ck(b"data", bytes(3200))), "no channels"),
    ("short fmt", _riff(_ck(b"fmt ", bytes(6)), _ck(b"data", bytes(3200))), "not 16"),
])
def test_a_broken_wav_is_one_line(tmp_path, kind, data, message):
    f = tmp_path / "rec.wav"
    f.write_bytes(data)
    r = _align(f)
    assert r.returncode == 2, (kind, r.stderr[-500:])
    lines = r.stderr.strip().splitlines()
    assert len(lines) == 1 and message in lines[0] and "rec.wav" in lines[0], r.stderr


def test_a_stream_whose_frames_change_layout_midway_decodes(tmp_path):
    av = pytest.importorskip("av")
    from mimika.speech.audio import read_media

    parts = []
    for layout in ("mono", "stereo"):  # two MP3 streams end to end: frames of two layouts
        f = tmp_path / f"{layout}.mp3"
        ch = 1 if layout == "mono" else 2
        with av.open(str(f), "w", options={"write_xing": "0", "id3v2_version": "0"}) as c:
            st = c.add_stream("libmp3lame", rate=16000, layout=layout)
            x = (np.sin(np.arange(16000) * 0.1) * 9000).astype(np.int16)
            fr = av.AudioFrame.from_ndarray(np.repeat(x[None, :], ch, axis=0).reshape(1, -1),
                                            format="s16", layout=layout)
            fr.sample_rate = 16000
            for p in [*st.encode(fr), *st.encode(None)]:
                c.mux(p)
        parts.append(f.read_bytes())
    both = tmp_path / "both.mp3"
    both.write_bytes(b"".join(parts))
    a, sr = read_media(both)
    assert sr == 16000 and 1.5 < len(a) / sr < 2.5


def test_a_wav_in_another_sample_format_goes_to_ffmpeg(tmp_path):
    av = pytest.importorskip("av")
    from mimika.speech.audio import read_media

    f = tmp_path / "alaw.wav"
    with av.open(str(f), "w", format="wav") as c:
        st = c.add_stream("pcm_alaw", rate=8000, layout="mono")
        fr = av.AudioFrame.from_ndarray((np.sin(np.arange(8000) * 0.1) * 9000).astype(
            np.int16)[None, :], format="s16", layout="mono")
        fr.sample_rate = 8000
        for p in [*st.encode(fr), *st.encode(None)]:
            c.mux(p)
    a, sr = read_media(f)
    assert sr == 8000 and len(a) == 8000 and 0.15 < np.abs(a).max() < 0.35
