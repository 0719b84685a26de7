"""Live Link Face CSV: our export as Unreal's and MotionBuilder's importers read it, real takes
round-tripped column by column, and timecodes that are not trusted."""

import csv

import numpy as np
import pytest

from conftest import MOTION_DIR, needs_motion
from mimika.errors import DataError, ParameterError
from mimika.io.arkit import LIVELINK_COLUMNS, aus_to_arkit
from mimika.io.livelink import livelink_rate, parse_timecode
from mimika.io.tracks import read_livelink_csv, read_track, write_track
from mimika.tracks import AUTrack

CHANNELS = ("AU01", "AU04L", "AU06", "AU12", "AU12R", "AU26", "AU30", "AU45", "AU51", "AU54",
            "AU61", "AU64")


def epic_import(path):
    """Epic's Live Link Face importer (ULiveLinkFaceImporterFactory, UE 5 LiveLinkFaceImporter
    plugin): lines split on ',' with empty fields culled; the header's first two keys must be
    Timecode and BlendShapeCount; InferFrameRate: 60 if any timecode's frame field (Atof of
    'FF.mmm') is > 30, else 30; SampleTime = H·3600 + M·60 + S + Frames / rate; every other
    column Atof'd into a property; a line with the wrong field count stops the import.
    Returns (rate, sample times, {property: values})."""
    with open(path, encoding="utf-8") as f:
        lines = [x for x in f.read().splitlines() if x]
    keys = [k for k in lines[0].split(",") if k]
    assert keys[:2] == ["Timecode", "BlendShapeCount"]
    rows = [[v for v in x.split(",") if v] for x in lines[1:]]
    rate = 60 if any(float(r[0].split(":")[3]) > 30.0 for r in rows) else 30
    times, values = [], []
    for r in rows:
        if len(r) != len(keys):
            break
        h, m, s, f = r[0].split(":")
        times.append(int(h) * 3600 + int(m) * 60 + int(s) + float(f) / rate)
        values.append([float(v) for v in r[2:]])
    v = np.array(values)
    return rate, np.array(times), {k: v[:, j] for j, k in enumerate(keys[2:])}


def motionbuilder_keys(path):
    """alexdjulin's llf_to_mh_mobu.py: pandas reads the CSV, values rounded to 4 decimals, each
    timecode string loses its last 4 characters ('.mmm') and becomes a (h, m, s, f) tuple of
    ints — the key of a dict {timecode: value} per blendshape — keyed on a 59.94 fps
    FBTimeCode. Returns the keyed frame numbers (on that clock) and their count of rows."""
    with open(path, encoding="utf-8") as f:
        rows = list(csv.DictReader(f))
    keys = [tuple(map(int, r["Timecode"][:-4].split(":"))) for r in rows]
    frames = sorted({((h * 60 + m) * 60 + s) * 60 + ff for h, m, s, ff in set(keys)})
    return np.array(frames), len(rows)


def wave_track(fps: float, seconds: float = 2.0) -> AUTrack:
    t = np.arange(round(seconds * fps))[:, None] / fps
    phase = np.linspace(0, 1, len(CHANNELS))[None, :]
    return AUTrack(0.45 + 0.45 * np.sin(2 * np.pi * (0.7 * t + phase)), CHANNELS, fps)


@pytest.mark.parametrize("fps", [24, 25, 30, 60, 120])
def test_export_plays_at_its_speed_in_unreal_and_keys_evenly_in_motionbuilder(tmp_path, fps):
    tr = wave_track(fps)
    p = write_track(tr, tmp_path / "take.csv", format="arkit")
    rate = livelink_rate(fps)
    assert rate == {24: 30, 25: 30, 30: 30, 60: 60, 120: 60}[fps]
    inferred, times, props = epic_import(p)
    assert inferred == 60  # the timecodes are on the app's 60 fps clock, and Unreal sees it
    assert np.allclose(np.diff(times), 1 / rate, atol=1e-9)  # real time: no half speed
    assert times[-1] - times[0] == pytest.approx((tr.n_frames - 1) / fps, abs=1 / rate)
    frames, n_rows = motionbuilder_keys(p)
    assert len(frames) == n_rows  # no two rows on one key (above 60 fps they would collide)
    assert set(np.diff(frames)) == {round(60 / rate)}  # every key the same distance apart
    # the values Unreal keys are the track's AUs as ARKit shapes at those times (±1e-6)
    src = tr.resample(fps=rate)
    shapes, rot = aus_to_arkit(src.values, src.channels)
    for j, name in enumerate(LIVELINK_COLUMNS[2:54]):
        assert np.abs(props[name] - shapes[:, j]).max() <= 1e-6, name
    assert np.abs(props["HeadYaw"] - rot[:, 0]).max() <= 1e-6
    back = read_track(p)  # … and back: every ARKit channel within 1e-6, and the AUs that
    assert back.fps == rate  # have one ARKit form (AU12 + AU12R comes back as AU12 + AU12R)
    again = aus_to_arkit(back.values, back.channels)
    assert np.abs(again[0] - shapes).max() <= 2e-6 and np.abs(again[1] - rot).max() <= 2e-6
    for c in ("AU01", "AU04L", "AU06", "AU30", "AU45", "AU51", "AU54", "AU61", "AU64"):
        assert np.abs(back[c] - src[c]).max() <= 2e-6, c


def test_short_take_still_reads_as_60_fps_in_unreal(tmp_path):
    tr = wave_track(30, seconds=0.3)  # 9 rows: on a clock from 0 they would stop at frame 16
    p = write_track(tr, tmp_path / "short.csv", format="arkit")
    inferred, times, _ = epic_import(p)
    assert inferred == 60 and np.allclose(np.diff(times), 1 / 30)
    assert read_track(p).n_frames == tr.n_frames


def test_jaw_direction_and_channels_without_an_au_survive(tmp_path):
    cols = list(LIVELINK_COLUMNS)
    rows = []
    for i in range(6):
        v = dict.fromkeys(cols[2:], 0.0)
        v.update(JawRight=0.5 + 0.05 * i, MouthClose=0.3, MouthLeft=0.2, MouthRight=0.1 * i,
                 JawOpen=0.4, LeftEyeRoll=0.05, RightEyeRoll=-0.04, EyeLookOutLeft=0.6,
                 EyeLookInRight=0.2, MouthRollLower=0.1, MouthRollUpper=0.5)
        rows.append([f"10:00:00:{2 * i:02d}.000", "61", *(f"{v[c]:.6f}" for c in cols[2:])])
    src = tmp_path / "in.csv"
    src.write_text("\n".join([",".join(cols), *(",".join(r) for r in rows)]) + "\n")
    tr = read_track(src)
    assert tr["AU30"][0] == pytest.approx(0.5)  # AU30 has no direction …
    out = write_track(tr, tmp_path / "out.csv", format="arkit")
    _, _, props = epic_import(out)
    assert np.allclose(props["JawRight"], [0.5 + 0.05 * i for i in range(6)], atol=1e-6)
    assert np.allclose(props["JawLeft"], 0, atol=1e-9)  # … but the jaw goes right again
    for name, want in (("MouthClose", 0.3), ("MouthLeft", 0.2), ("LeftEyeRoll", 0.05),
                       ("RightEyeRoll", -0.04), ("EyeLookOutLeft", 0.6),
                       ("EyeLookInRight", 0.2), ("MouthRollLower", 0.1),
                       ("MouthRollUpper", 0.5)):
        assert np.allclose(props[name], want, atol=1e-6), name
    assert np.allclose(props["MouthRight"], [0.1 * i for i in range(6)], atol=1e-6)


def test_a_track_made_by_mimika_writes_au30_as_jaw_left(tmp_path):
    tr = AUTrack(np.full((3, 1), 0.7), ("AU30",), 30)
    _, _, props = epic_import(write_track(tr, tmp_path / "j.csv", format="arkit"))
    assert np.allclose(props["JawLeft"], 0.7) and np.allclose(props["JawRight"], 0)


@needs_motion
@pytest.mark.parametrize("take", ["S88-001", "apfel"])
def test_real_take_round_trips_every_column(tmp_path, take):
    src = MOTION_DIR / f"{take}.csv"
    out = write_track(read_track(src), tmp_path / "rt.csv", format="arkit")
    with open(src, encoding="utf-8") as f:
        orig = list(csv.reader(f))[1:]
    _, times, props = epic_import(out)
    frames = np.array([parse_timecode(r[0], fps=60) for r in orig])
    idx = np.concatenate([[0], np.cumsum(np.round(np.diff(frames) / 2))]).astype(int)
    tracked = [(k, r) for k, r in zip(idx, orig, strict=True) if r[1] != "0"]
    worst = {}
    for j, name in enumerate(LIVELINK_COLUMNS[2:]):
        a = np.array([float(r[j + 2]) for _, r in tracked])
        if j < 52:
            a = np.clip(a, 0, 1)  # ARKit shapes are 0–1; a few takes exceed 1 slightly
        worst[name] = np.abs(props[name][[k for k, _ in tracked]] - a).max()
    assert max(worst.values()) <= 2e-6, {k: v for k, v in worst.items() if v > 2e-6}
    assert len(times) == idx[-1] + 1


# -- timecodes not trusted ----------------------------------------------------------------------
def _take(tmp_path, stamps, name="t.csv"):
    cols = ",".join(LIVELINK_COLUMNS)
    zeros = ",".join(["0.1"] * (len(LIVELINK_COLUMNS) - 2))
    p = tmp_path / name
    p.write_text(cols + "\n" + "".join(f"{s},61,{zeros}\n" for s in stamps))
    return p


@pytest.mark.parametrize("stamps, message", [
    (["00:00:00:00.000", "00:00:00:04.000", "00:00:00:02.000", "00:00:00:06.000"],
     r"t.csv:4:Timecode: not after line 3's timecode"),
    (["00:00:00:00.000", "99:00:00:00.000"], r"t.csv:3:Timecode: .*hour 99 is not 0–23"),
    (["99:00:00:00.000", "00:00:00:04.000"], r"t.csv:2:Timecode: .*hour 99"),
    (["00:00:00:00.000", "00:00:00:02.000", "00:10:00:00.000"],
     r"t.csv:4:Timecode: 600 s after line 3, more than the 2 s"),
    (["00:00:00:00.000", "00:00:00:02.000", "00:00:00:02.000"], r"t.csv:4:Timecode: not after"),
    (["00:00:00:70.000", "00:00:00:72.000"], r"frame 70 is not below the clock's 60 fps"),
    (["00:00:00:00.000", "00:00:60:00.000"], r"second 60 is not 0–59"),
    (["00:00:00:00.000", "yesterday"], r"t.csv:3:Timecode: 'yesterday' is not a timecode"),
    (["00:00:00:00.000", "00:00:00:00.001", "00:00:00:00.002"], r"rows come 3e\+04 times"),
])
def test_bad_timecodes_are_refused_with_the_line(tmp_path, stamps, message):
    with pytest.raises(DataError, match=message):
        read_livelink_csv(_take(tmp_path, stamps))


def test_repair_sorts_drops_duplicates_and_keeps_the_longest_stretch(tmp_path):
    stamps = ["00:00:00:00.000", "00:00:00:04.000", "00:00:00:02.000", "00:00:00:06.000",
              "00:00:00:06.000", "05:00:00:00.000", "00:00:00:08.000"]
    tr = read_livelink_csv(_take(tmp_path, stamps), timecodes="repair", timecode_fps=60)
    assert tr.n_frames == 5 and tr.fps == 30
    assert "2 rows moved" not in tr.meta["notes"][0]
    assert "1 duplicates dropped, 1 rows outside" in tr.meta["notes"][0]


def test_take_across_midnight_and_a_raised_max_gap(tmp_path):
    tr = read_livelink_csv(_take(tmp_path, ["23:59:59:56.000", "23:59:59:58.000",
                                            "00:00:00:00.000", "00:00:00:02.000"]))
    assert tr.n_frames == 4
    p = _take(tmp_path, ["00:00:00:40.000", "00:00:00:42.000", "00:00:03:42.000"], "gap.csv")
    with pytest.raises(DataError, match="more than the 2 s"):
        read_livelink_csv(p)
    assert read_livelink_csv(p, max_gap=5).n_frames == 92  # 3 s at 30 fps, filled
    with pytest.raises(DataError, match="would need 324,003 frames"):  # before allocating
        read_livelink_csv(_take(tmp_path, ["00:00:00:40.000", "00:00:00:42.000",
                                           "00:00:00:44.000", "03:00:00:44.000"], "big.csv"),
                          max_gap=20000)


def test_clock_is_inferred_like_unreal(tmp_path):
    # a 30 fps clock (no frame number above 30): rows every frame are 30 fps, not 60
    tr = read_livelink_csv(_take(tmp_path, [f"00:00:01:{i:02d}.000" for i in range(10)]))
    assert tr.fps == 30 and tr.meta["timecode_fps"] == 30


def test_writer_options(tmp_path):
    tr = wave_track(30, seconds=1)
    with pytest.raises(ParameterError, match="30 or 60 fps clock"):
        write_track(tr, tmp_path / "x.csv", format="arkit", timecode_fps=25)
    with pytest.raises(ParameterError, match="faster than the 60 fps"):
        write_track(tr, tmp_path / "x.csv", format="arkit", fps=120)
    p = write_track(tr, tmp_path / "s.csv", format="arkit", start="10:00:00:00.000")
    assert p.read_text().splitlines()[1].startswith("10:00:00:00.000,61,")
