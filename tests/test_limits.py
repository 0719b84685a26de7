"""Issue 20's reproducers: each entry point refuses what it cannot finish — one line naming the
limit and how to raise it, exit code 2 — or gives a bounded, correct result (the studio's
are in test_studio_abuse.py, killed renders in test_interrupt.py)."""

from __future__ import annotations

import json
import os
import subprocess
import sys

import pytest

from mimika import limits
from mimika.cli import main
from mimika.errors import DataError, MimikaError


def run(capsys, *argv: str) -> tuple[int, str, str]:
    code = main(list(argv))
    out, err = capsys.readouterr()
    return code, out, err


def one_error_line(err: str) -> str:
    lines = [x for x in err.splitlines() if x.strip()]
    assert lines and lines[0].startswith("mimika: error: "), err
    assert "Traceback" not in err
    return err


@pytest.fixture
def no_speech(monkeypatch):
    """Synthesis fails the test: refusals must come before it."""
    def boom(*a, **k):
        raise AssertionError("espeak-ng was started for input that had to be refused")

    monkeypatch.setattr("mimika.speech.espeak.synth", boom)


# -- the limits themselves -----------------------------------------------------------------------
def test_refusals_name_the_limit_and_how_to_raise_it():
    with pytest.raises(limits.LimitError) as e:
        limits.check_timeline(36000, 120)
    assert e.value.limit == "max_duration"
    assert str(e.value) == ("the timeline is 36 000 s long, over the limit of 3 600 s "
                            "(max_duration); raise it with --max-duration or MIMIKA_MAX_DURATION")
    with pytest.raises(limits.LimitError, match=r"needs 300 001 frames.*max_frames.*--max-frames"):
        limits.check_timeline(300, 1000)
    with pytest.raises(limits.LimitError, match=r"max_fps.*MIMIKA_MAX_FPS"):
        limits.check_fps(1e9)


def test_environment_and_override_raise_limits(monkeypatch):
    monkeypatch.setenv("MIMIKA_MAX_DURATION", "40000")
    assert limits.current().max_duration == 40000.0
    assert limits.check_timeline(36000, 1) == 36001
    with limits.override(max_duration=10, max_frames=None):
        assert limits.current().max_duration == 10.0
        assert limits.current().max_frames == limits.DEFAULTS.max_frames
    assert limits.current().max_duration == 40000.0
    monkeypatch.setenv("MIMIKA_MAX_FRAMES", "lots")
    with pytest.raises(MimikaError, match="MIMIKA_MAX_FRAMES='lots' must be a positive number"):
        limits.current()
    with pytest.raises(MimikaError, match="must be a positive number"), limits.override(
            max_duration=-1):
        pass


@pytest.mark.parametrize(("text", "where", "what"), [
    ('{"a": [1, NaN]}', "a[1]", "NaN is not a number"),
    ('{"a": Infinity}', "a:", "Infinity is not a number"),
    ('{"a": 1e999}', "a:", "too large"),
    ('{"a": 1' + "0" * 400 + "}", "a:", "401-digit integer"),
    ('{"a": 1' + "0" * 5000 + "}", "a:", "5001-digit integer"),
    ("[" * 100_000 + "]" * 100_000, "x.json", "nested deeper than 64 levels"),
    ('{"a": ' + "[" * 70 + "]" * 70 + "}", "a[0]", "nested deeper than 64 levels"),
    ('{"a": ', "x.json:1:7", "invalid JSON"),
])
def test_hostile_json_is_one_data_error_with_a_place(text, where, what):
    with pytest.raises(DataError) as e:
        limits.loads_json(text, "x.json")
    assert where in str(e.value) and what in str(e.value)


# -- item 4: rendering ---------------------------------------------------------------------------
def test_a_50000_word_article_is_refused_before_synthesis(tmp_path, capsys, no_speech):
    art = tmp_path / "article.txt"
    art.write_text("This is a sentence of the news. " * 7143)  # 50 001 words
    out = tmp_path / "news.mp4"
    code, _, err = run(capsys, "news", str(art), "-o", str(out))
    assert code == 2
    assert "min to say" in one_error_line(err) and "--max-duration" in err
    assert not out.exists()


def test_the_limit_can_be_raised_for_a_long_article(tmp_path, no_speech):
    art = tmp_path / "article.txt"
    art.write_text("This is a sentence of the news. " * 7143)
    with pytest.raises(AssertionError, match="espeak-ng was started"):  # past the limit
        main(["news", str(art), "-o", str(tmp_path / "n.mp4"), "--max-duration", "20000"])


@pytest.mark.parametrize("argv", [["news", "--example", "en", "--fps", "100000"],
                                  ["render", "SCRIPT", "--fps", "1e9"],
                                  ["render", "SCRIPT", "--fps", "inf"]])
def test_absurd_frame_rates_are_refused(tmp_path, capsys, no_speech, argv):
    script = tmp_path / "s.xml"
    script.write_text("<speak>Hello there.</speak>")
    out = tmp_path / ("o.mp4" if argv[0] == "news" else "o.csv")
    code, _, err = run(capsys, *[str(script) if a == "SCRIPT" else a for a in argv],
                       "-o", str(out))
    assert code == 2 and "fps" in one_error_line(err)
    assert not out.exists()


def test_a_36000_s_break_is_refused_where_it_is_written(tmp_path, capsys):
    script = tmp_path / "s.xml"
    script.write_text('<speak>Hello\n<break time="36000s"/> there</speak>')
    out = tmp_path / "o.glb"
    code, _, err = run(capsys, "render", str(script), "-o", str(out))
    assert code == 2
    assert f"{script}:2:1: break time='36000s' is 36 000 s long" in one_error_line(err)
    assert "max_duration" in err and not out.exists()


def test_raising_max_duration_renders_the_long_script_completely(tmp_path, capsys):
    script = tmp_path / "s.xml"
    script.write_text('<speak>Hello <break time="36000s"/> there</speak>')
    out = tmp_path / "o.csv"
    code, _, err = run(capsys, "render", str(script), "-o", str(out), "--fps", "1",
                       "--max-duration", "40000")
    assert code == 0, err
    rows = out.read_text().splitlines()
    assert 36000 < len(rows) - 1 < 36010
    assert float(rows[-1].split(",")[0]) > 36000


def test_a_script_event_past_the_limit_is_refused_with_its_place(tmp_path, capsys):
    script = tmp_path / "s.xml"
    script.write_text('<speak>Hi <m:aus set="AU12" start="36000s" dur="1s"/></speak>')
    code, _, err = run(capsys, "render", str(script), "-o", str(tmp_path / "o.csv"))
    assert code == 2
    assert f"mimika: error: {script}:1:11: the aus event ends at 36001 s" in one_error_line(err)
    assert err.count(str(script)) == 1 and "max_duration" in err


# -- item 6 and 9: batch YAML --------------------------------------------------------------------
LOL = "\n".join(["a: &a [lol, lol, lol, lol, lol, lol, lol, lol, lol]"] + [
    f"{c}: &{c} [{', '.join([f'*{p}'] * 9)}]" for p, c in zip("abcdefgh", "bcdefghi",
                                                               strict=True)])


@pytest.mark.parametrize(("spec", "line", "what"), [
    (LOL, 7, "max_aliases"),
    ("aus: [[AU12]]\nx: &x {y: *x}", 2, "endless loop"),
    ("aus: [[AU12]]\nneutral: \x01\n", 2, "control characters"),
    ("aus: " + "[" * 5000 + "]" * 5000, 1, "nested more than 64 levels"),
    ("aus: [[AU12]]\nsample:\n  count: 1" + "0" * 400, 3, "401-digit integer"),
    ("aus: [[AU12]]\nseed: " + "9" * 5000, 2, "5000-digit integer"),
    ("aus: [[AU12]]\nneutral: !!foo x", 2, "!!foo"),
    ("aus: [[AU12]]\nneutral: !!int 1.0", 2, "!!int"),
    ("aus: [[AU12]]\nneutral: !!timestamp x", 2, "!!timestamp"),
    ("aus: [[AU12]]\nneutral: !!int", 2, "!!int"),
    ("aus: [[AU12]]\nintensities: [.nan]", 2, "not a finite number"),
    ("aus: [[AU12]]\nsample: {count: 100000000000}", 2, "max_items"),
])
def test_hostile_batch_specs_get_one_error_at_their_line(tmp_path, capsys, spec, line, what):
    p = tmp_path / "spec.yaml"
    p.write_text(spec)
    code, _, err = run(capsys, "batch", str(p), "-o", str(tmp_path / "out"), "--dry-run")
    assert code == 2
    assert f"{p}:{line}:" in one_error_line(err) and what in err


def test_the_alias_budget_still_allows_ordinary_anchors(tmp_path, capsys):
    p = tmp_path / "spec.yaml"
    p.write_text("aus: &sets [[AU12], [AU06]]\nintensities: &k [0.5, 1]\nviews: [front]\n")
    code, out, err = run(capsys, "batch", str(p), "-o", str(tmp_path / "out"), "--dry-run")
    assert code == 0, err
    assert "4 items" in out


# -- item 7: projects ----------------------------------------------------------------------------
def _project(**settings) -> str:
    return json.dumps({"format": "mimika-project", "version": 1,
                       "settings": {"fps": 25, **settings},
                       "timeline": {"channels": []}})


@pytest.mark.parametrize(("text", "what"), [
    (_project().replace('"fps": 25', '"fps": 1' + "0" * 400), "settings.fps: a 401-digit"),
    (_project().replace('"fps": 25', '"fps": 1' + "0" * 5000), "settings.fps: a 5001-digit"),
    (_project().replace('"channels": []', '"channels": ' + "[" * 100_000 + "]" * 100_000),
     "nested deeper than 64 levels"),
    (_project().replace('"fps": 25', '"fps": NaN'), "settings.fps: NaN"),
    (_project().replace('"channels": []', '"channels": [], "rate": Infinity'),
     "timeline.rate: Infinity"),
    (_project().replace('"channels": []', '"channels": [{"name": "face", "events": [{"kind": '
                        '"blink", "start": 1e7, "duration": 0.3}]}]'), "max_duration"),
])
def test_hostile_projects_fail_the_check_with_a_place(tmp_path, capsys, text, what):
    p = tmp_path / "p.json"
    p.write_text(text)
    code, _, err = run(capsys, "project", "check", str(p))
    assert code == 2 and what in one_error_line(err)


# -- item 10 -------------------------------------------------------------------------------------
def test_an_empty_script_is_an_error_not_one_frame(tmp_path, capsys):
    script = tmp_path / "empty.xml"
    script.write_text("")
    code, _, err = run(capsys, "render", str(script), "-o", str(tmp_path / "o.glb"))
    assert code == 2 and "nothing to render" in one_error_line(err)


def test_a_600_kb_script_is_refused_not_800001_frames(tmp_path, capsys):
    script = tmp_path / "big.txt"
    script.write_text("word " * 120_000)
    out = tmp_path / "o.csv"
    code, _, err = run(capsys, "render", str(script), "-o", str(out))
    assert code == 2 and "max_text" in one_error_line(err) and not out.exists()
    script.write_text("word " * 80_000)  # under max_text: its speech is too long
    code, _, err = run(capsys, "render", str(script), "-o", str(out))
    assert code == 2 and "max_duration" in one_error_line(err) and not out.exists()


@pytest.mark.parametrize(("entry", "what"), [
    ({"name": 5, "aus": {"AU12": 1}}, "expressions[0].name: must be a name"),
    ({"name": "Bad Name", "aus": {"AU12": 1}}, "expressions[0].name: 'Bad Name'"),
    ({"name": "ok", "aus": {"AU12": "x"}}, "expressions[0].aus: AU12 'x' is not a number"),
    ({"name": "ok", "aus": {"AU12": 1}, "onset": "nan"}, "expressions[0].onset"),
    ({"name": "ok", "aus": 7}, "expressions[0].aus: must be an object"),
    ("not an object", "expressions[0]: must be an object"),
])
def test_malformed_library_entries_are_one_error_with_a_place(tmp_path, monkeypatch, capsys,
                                                               entry, what):
    monkeypatch.setenv("MIMIKA_DATA_DIR", str(tmp_path))
    (tmp_path / "expressions.json").write_text(json.dumps({"version": 1,
                                                           "expressions": [entry]}))
    code, _, err = run(capsys, "expressions", "list")
    assert code == 2 and what in one_error_line(err)


def _dead_pid() -> int:
    p = subprocess.Popen([sys.executable, "-c", "pass"])
    p.wait()
    return p.pid


def test_temp_files_of_killed_saves_are_swept_at_the_next_start(tmp_path):
    from mimika.knowledge.expressions import ExpressionLibrary

    lib = tmp_path / "expressions.json"
    stale = tmp_path / f".expressions.json.{_dead_pid()}.k3j2h1.tmp"
    live = tmp_path / f".expressions.json.{os.getpid()}.a8d7f6.tmp"  # a save in progress
    other = tmp_path / ".notes.txt.12.x.tmp"
    for p in (stale, live, other):
        p.write_text("{")
    ExpressionLibrary(lib).create("my-smile", {"AU12": 0.8})
    assert not stale.exists() and live.exists() and other.exists()
    assert [p.name for p in tmp_path.iterdir() if p.name.endswith(".tmp")].count(
        live.name) == 1


def test_the_speech_cache_is_capped_in_bytes(tmp_path):
    import numpy as np

    from mimika.studio.state import SpeechEntry, SpeechSegment, StudioState
    from mimika.tracks import AUTrack

    class Utt:
        def __init__(self, seconds: float):
            self.audio = np.zeros(int(seconds * 22050), np.float32)
            self.sr = 22050
            self.duration = seconds

    st = StudioState(tmp_path / "projects")
    mouth = AUTrack(np.zeros((10, 1), np.float32), ("AU25",), 30)
    with limits.override(max_cache_mb=40):
        for i in range(32):  # 32 × 24 MB: 768 MB before
            e = SpeechEntry(f"k{i:02d}", "x", "en", 175)
            e.segments.append(SpeechSegment("x", 0, 0.0, Utt(272.0), mouth))
            st.put_speech(e)
    held = sum(e.nbytes for e in st._speech.values())
    assert held <= 40e6 and st.get_speech("k31") is not None and st.get_speech("k00") is None
