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
