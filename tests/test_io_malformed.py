"""Every file reader of mimika.io turns malformed input into one MimikaError with a place —
never another exception. Seeded mutations of small valid files: a bounded smoke test
(``MIMIKA_FUZZ_CASES=3000`` runs more per reader; the hypothesis suite runs the large numbers)."""

import os
import random

import numpy as np
import pytest

from mimika.errors import MimikaError
from mimika.io.tracks import read_track, write_track
from mimika.io.visemes import read_rhubarb_json, read_viseme_weights, write_viseme_weights
from mimika.tracks import AUTrack

PYFEAT = ("FaceRectX,FaceRectY,FaceRectWidth,FaceRectHeight,FaceScore,Pitch,Roll,Yaw,AU12,"
          "gaze_pitch,gaze_yaw,mouthSmileLeft,mouthSmileRight,input,frame,approx_time\n"
          + "".join(f"0,0,100,100,0.99,0.01,0.02,0.03,0.5,0.0,0.0,0.3,0.4,v.mp4,{2 * i},00:0{i}\n"
                    for i in range(6)))
RHUBARB = ('{"metadata": {"soundFile": "/a.wav", "duration": 0.3}, "mouthCues": ['
           '{"start": 0.0, "end": 0.1, "value": "X"}, {"start": 0.1, "end": 0.3, "value": "A"}]}')
TOKENS = ["", ",", "\n", "nan", "inf", "-1", "1e309", "99:99:99:99.999", "\x00", "AU99", "é",
          "\"", "0", "1e-300", "00:00:00:00.000", "{", "]", "-0", "9" * 400, " "]


def mutate(text: str, rng: random.Random) -> str:
    ops = rng.randint(1, 4)
    for _ in range(ops):
        k = rng.randrange(len(text) + 1) if text else 0
        op = rng.random()
        if op < 0.3:  # delete a span
            text = text[:k] + text[k + rng.randint(1, 12):]
        elif op < 0.6:  # insert a hostile token
            text = text[:k] + rng.choice(TOKENS) + text[k:]
        elif op < 0.8:  # duplicate or swap lines
            lines = text.split("\n")
            i, j = rng.randrange(len(lines)), rng.randrange(len(lines))
            lines[i], lines[j] = lines[j], lines[i]
            if rng.random() < 0.5:
                lines.insert(i, lines[j])
            text = "\n".join(lines)
        else:  # cut the file
            text = text[:k]
    return text


def sources(tmp_path):
    tr = AUTrack(np.linspace(0, 1, 8)[:, None] * [0.2, 0.7, 0.4], ("AU12", "AU26", "AU52"), 30)
    out = {}
    for fmt in ("au", "openface", "arkit"):
        out[fmt] = write_track(tr, tmp_path / f"{fmt}.csv", format=fmt).read_text()
    out["pyfeat"] = PYFEAT
    cues = [{"start": 0.0, "end": 0.1, "value": "PP"}, {"start": 0.1, "end": 0.2, "value": "aa"}]
    out["weights.csv"] = write_viseme_weights(tmp_path / "w.csv", cues, fps=20,
                                              duration=0.2).read_text()
    out["weights.json"] = write_viseme_weights(tmp_path / "w.json", cues, fps=20,
                                               duration=0.2).read_text()
    out["rhubarb"] = RHUBARB
    return out


READERS = {"au": read_track, "openface": read_track, "arkit": read_track, "pyfeat": read_track,
           "weights.csv": read_viseme_weights, "weights.json": read_viseme_weights,
           "rhubarb": read_rhubarb_json}


@pytest.mark.parametrize("kind", list(READERS))
def test_mutated_files_give_mimika_errors_only(tmp_path, kind):
    text = sources(tmp_path)[kind]
    rng = random.Random(f"mimika-{kind}")
    suffix = ".json" if kind in ("weights.json", "rhubarb") else ".csv"
    outcomes = {"ok": 0, "error": 0}
    for i in range(int(os.environ.get("MIMIKA_FUZZ_CASES", 150))):
        p = tmp_path / f"m{i}{suffix}"
        p.write_text(mutate(text, rng), encoding="utf-8", errors="surrogatepass")
        try:
            READERS[kind](p)
            outcomes["ok"] += 1
        except MimikaError as e:
            msg = str(e)
            assert "\n" not in msg and str(p) in msg, msg  # one line, naming the file
            outcomes["error"] += 1
    assert outcomes["error"] > 20 and outcomes["ok"] > 0, outcomes


def test_non_utf8_and_folders(tmp_path):
    bad = tmp_path / "bin.csv"
    bad.write_bytes(b"time,AU12\n0,\xff\xfe\n")
    with pytest.raises(MimikaError, match="not UTF-8"):
        read_track(bad)
    with pytest.raises(MimikaError, match="is a folder"):
        read_track(tmp_path)
