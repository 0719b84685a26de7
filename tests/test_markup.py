"""Script language: parsing, errors with line:col, exact round trips, doc examples, fuzzing."""

import re
from pathlib import Path

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from mimika.errors import MimikaError
from mimika.markup import ScriptError, parse_script, to_script
from mimika.timeline import sample

DOC = Path(__file__).resolve().parents[1] / "docs" / "script.md"

SCRIPT = """<speak xmlns:m="https://mimika.dev/ns/1">
  <m:channel name="head" override="true"/>
  <p>Hello there. <m:expr name="happiness" intensity="0.6">Good news</m:expr>, everyone!
  <break time="500ms"/><m:blink/> <m:nod count="2" at="+0.2s">Yes</m:nod>.
  <prosody rate="slow"><tilt dir="left" channel="head">really</tilt></prosody>
  <m:gaze dir="left" start="4s" dur="1s"/></p>
</speak>"""


def roundtrip(tl):
    again = parse_script(to_script(tl))
    assert again == tl
    return again


def test_parse_wrapping_point_and_absolute_elements():
    tl = parse_script(SCRIPT)
    evs = {e.label: (c, e) for c, e in tl.events}
    ch, happy = evs["happiness"]
    assert ch == "face" and happy.intensity == 0.6 and happy.anchor[1] > happy.anchor[0]
    assert evs["gaze left"][1].start == 4.0 and evs["gaze left"][1].anchor is None
    assert evs["nod×2"][1].at == 0.2
    assert tl.channel("head").override
    roundtrip(tl)


def test_expression_spans_its_words_and_breaks_shift_time():
    a = parse_script("<speak>One two <expr name='happiness'>three</expr></speak>")
    b = parse_script("<speak>One two <break time='1s'/><expr name='happiness'>three</expr>"
                     "</speak>")
    ea, eb = a.events[0][1], b.events[0][1]
    assert eb.start == pytest.approx(ea.start + 1.0)
    # 'three' has 2 vowel units at 0.16 s each
    assert ea.duration == pytest.approx(0.32)


def test_plain_text_is_a_script():
    tl = parse_script("Just words, <no> markup & more")
    assert tl.speech.text == "Just words, <no> markup & more" and not tl.channels
    roundtrip(tl)
    assert parse_script("") == parse_script("   ")


def test_printed_script_is_pleasant():
    out = to_script(parse_script(SCRIPT))
    assert '<m:expr name="happiness" intensity="0.6">Good news</m:expr>' in out
    assert '<m:gaze dir="left" start="4s"/>' in out


@pytest.mark.parametrize("text, line, col, pattern", [
    ("<speak>\n  <p>Hi</s></speak>", 2, 10, "mismatched tag"),
    ("<speak>\n<m:expresion name='x'/></speak>", 2, 1, "did you mean 'expression'"),
    ("<speak><expr nme='happiness'/></speak>", 1, 8, "did you mean 'name'"),
    ("<speak>\n\n  <m:expr name='hapiness'>x</m:expr></speak>", 3, 3, "did you mean happiness"),
    ("<speak><m:expr name='happiness' start='-1s'/></speak>", 1, 8, "not a time"),
    ("<speak><m:blink at='-5s'/></speak>", 1, 8, "before the script begins"),
    ("<speak><m:expr name='happiness' start='0s' dur='2s'/>\n"
     "<m:expr name='sadness' start='1s'/></speak>", 2, 1, "overlaps"),
    ("<speak><m:gaze dir='lfet'/></speak>", 1, 8, "did you mean 'left'"),
    ("<speak><break time='soon'/></speak>", 1, 8, "not a time"),
    ("<speak><x:expr xmlns:x='urn:other'/></speak>", 1, 8, "namespace"),
    ("<speak><m:blink/></speak> trailing <b/>", 1, 27, "junk after document"),
    ("<speak>Tom & Jerry</speak>", 1, 13, "malformed XML"),
    ("<speak><m:aus set='AU99=1'/></speak>", 1, 8, "unknown Action Unit"),
    ("<speak><m:expr name='happiness' start='1s' at='+1s'/></speak>", 1, 8, "not both"),
])
def test_errors_have_line_col_and_hint(text, line, col, pattern):
    with pytest.raises(ScriptError) as ei:
        parse_script(text, source="s.xml")
    e = ei.value
    assert re.search(pattern, str(e)), str(e)
    assert (e.line, e.col) == (line, col), str(e)
    assert str(e).startswith(f"s.xml:{line}:{col}: ")


def test_error_position_without_speak_root():
    with pytest.raises(ScriptError) as ei:
        parse_script("<p>Hi <m:nodd/></p>")
    assert (ei.value.line, ei.value.col) == (1, 7)


def _doc_examples():
    return re.findall(r"```xml\n(.*?)```", DOC.read_text("utf-8"), re.DOTALL)


def test_doc_has_examples():
    assert len(_doc_examples()) >= 5


@pytest.mark.parametrize("i", range(len(_doc_examples())))
def test_every_doc_example_parses_roundtrips_and_samples(i):
    tl = parse_script(_doc_examples()[i], source=f"script.md example {i + 1}")
    roundtrip(tl)
    sample(tl, fps=25)


def test_doc_python_example_runs():
    code = re.findall(r"```python\n(.*?)```", DOC.read_text("utf-8"), re.DOTALL)
    assert code
    for block in code:
        exec(compile(block, "docs/script.md", "exec"), {})


# -- fuzzing ---------------------------------------------------------------------------------
XMLISH = st.lists(st.sampled_from([*"<>/=\"' &;abmex:rpnsk!?.,-1\n",
                                           "<m:expr name='happiness'>", "</m:expr>", "<speak>",
                                           "</speak>", "<break time='1s'/>", "<m:blink/>",
                                           "at='+1s'", "<p>", "</p>", "&amp;", "<!--", "-->",
                                           "<m:nod count='3'/>", "<![CDATA[x]]>"]),
                  max_size=40).map("".join)


@settings(max_examples=100, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(XMLISH)
def test_fuzz_parser_only_raises_mimika_errors(text):
    try:
        tl = parse_script(text)
    except MimikaError:
        return
    assert parse_script(to_script(tl)) == tl


@settings(max_examples=100, deadline=None)
@given(st.integers(0, len(SCRIPT) - 1), st.integers(0, 5), st.text(max_size=4))
def test_fuzz_mutated_valid_script(pos, cut, insert):
    text = SCRIPT[:pos] + insert + SCRIPT[pos + cut:]
    try:
        tl = parse_script(text)
    except MimikaError:
        return
    assert parse_script(to_script(tl)) == tl
