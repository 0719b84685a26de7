"""AU Blender: every Appendix C rule, the trace, properties and malformed rule files."""

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from mimika.errors import DataError, ParameterError
from mimika.facs.blender import Blender, blend, blend_frames, blend_track, default_rules
from mimika.tracks import AUTrack

RULES = default_rules()


def trapezoid(v, a, b, c, d):
    """Independent reference for the documented fuzzy sets."""
    up = 1.0 if v >= b else (0.0 if v <= a else (v - a) / (b - a))
    down = 1.0 if v <= c else (0.0 if v >= d else (d - v) / (d - c))
    return min(up, down)


def mu_x(v):
    return trapezoid(v, 0.0, 0.0, 0.1, 0.4)


def mu_z(v):
    return trapezoid(v, 0.6, 0.9, 1.0, 1.0)


def code(n):
    return f"AU{n:02d}"


APPENDIX_C = {
    "domination": "5<63 7<6 7<9 10<9 17<28 23<18 23<28 24<18 24<20 24<23 24<28 61<43 62<43 "
                  "63<43 64<43",
    "combination": "16<12+18 16<12+20 16<12+22 16<12+23 16<18+20 16<18+23 16<20+22 16<20+23 "
                   "16<22+23 18<20+23 24<9+17 24<10+17 24<12+17 24<17+22 24<17+23",
    "strong": "10<12Z 12<15Z",
    "exclusion": "12@20 15@20 15@22 16@28 18@20 18@28 22@28 24@25 24@26 24@27 25@26 25@27 "
                 "25@28 26@27",
    "opposition": "5@43 51@52 53@54 55@56 57@58 61@62 63@64",
}


def test_every_appendix_c_rule_is_parsed_with_its_kind():
    got = {}
    for r in RULES:
        got.setdefault(r.kind, []).append(r.notation)
    assert {k: " ".join(v) for k, v in got.items()} == APPENDIX_C
    assert len(RULES) == 53


def _expected(rule, a, b, c=0.0):
    """Expected outputs computed from the seed's formulas (independent of the implementation)."""
    nums = [int(x) for x in rule.replace("Z", "").replace("<", " ").replace("@", " ")
            .replace("+", " ").split()]
    if "<" in rule:
        target, doms = nums[0], nums[1:]
        vals = {code(target): a, code(doms[0]): b}
        if len(doms) == 2:
            vals[code(doms[1])] = c
            d = min(b, c)
        else:
            d = mu_z(b) if rule.endswith("Z") else b
        return vals, {code(target): min(1 - d, a)}
    first, second = nums
    return {code(first): a, code(second): b}, None


@pytest.mark.parametrize("rule", [r.notation for r in RULES])
@pytest.mark.parametrize(("a", "b", "c"), [(0.8, 1.0, 0.9), (0.6, 0.3, 0.5), (0.5, 0.95, 0.2)])
def test_rule_numeric(rule, a, b, c):
    r = Blender.default().rule(rule)
    vals, exp = _expected(rule, a, b, c)
    only = Blender([r])  # the rule alone, so other rules cannot interfere
    out = only.blend(vals).aus
    if r.kind == "exclusion":
        first, second = code(int(rule.split("@")[0])), code(int(rule.split("@")[1]))
        exp = {second: min(mu_x(a), b)}
    elif r.kind == "opposition":
        first, second = code(int(rule.split("@")[0])), code(int(rule.split("@")[1]))
        exp = {first: max(0.0, a - b), second: max(0.0, b - a)}
    for k, v in exp.items():
        assert out[k] == pytest.approx(v, abs=1e-6), (rule, vals, out)


def test_seed_examples():
    assert blend({"AU06": 1, "AU07": 0.8}).aus == {"AU06": 1.0, "AU07": 0.0}
    assert blend({"AU06": 0.3, "AU09": 0.5, "AU07": 0.8}).aus["AU07"] == pytest.approx(0.5)
    assert blend({"AU20": 0.6, "AU23": 0.9, "AU18": 0.7}).aus["AU18"] == pytest.approx(0.4)
    assert blend({"AU15": 0.75, "AU12": 0.9}).aus["AU12"] == pytest.approx(0.5)  # mu_z = .5
    assert blend({"AU15": 0.5, "AU12": 0.9}).aus["AU12"] == pytest.approx(0.9)  # not strong
    assert blend({"AU18": 0.25, "AU28": 1.0}).aus["AU28"] == pytest.approx(0.5)
    assert blend({"AU51": 0.7, "AU52": 0.3}).aus == pytest.approx({"AU51": 0.4, "AU52": 0.0})


def test_outputs_are_computed_from_inputs_not_chained():
    # 12@20 removes AU20, but 16<12+20 still reads the input AU20
    out = blend({"AU12": 1.0, "AU20": 0.9, "AU16": 0.7}).aus
    assert out["AU20"] == 0.0 and out["AU16"] == pytest.approx(0.1)


def test_several_rules_on_one_au_combine_with_min():
    out = blend({"AU24": 0.9, "AU18": 0.3, "AU20": 0.5, "AU23": 0.2})
    assert out.aus["AU24"] == pytest.approx(0.5)
    assert {t.rule for t in out.trace} >= {"24<18", "24<20"}


def test_trace_names_the_rule_and_its_values():
    res = blend({"AU06": 1.0, "AU07": 0.8, "AU12": 0.5})
    assert len(res.trace) == 1
    t = res.trace[0]
    assert t.rule == "7<6"
    assert t.inputs == {"AU06": 1.0, "AU07": 0.8}
    assert t.outputs == {"AU07": 0.0}
    assert res.to_dict()["trace"][0]["rule"] == "7<6"


def test_no_trace_when_nothing_changes():
    assert blend({"AU01": 0.5, "AU02": 0.5}).trace == []


def test_disabled_rule_by_notation():
    assert blend({"AU06": 1, "AU07": 0.8}, disabled={"7<6"}).aus["AU07"] == 0.8
    assert blend({"AU51": 0.5, "AU52": 0.5}, disabled=["52@51"]).aus["AU51"] == 0.5
    with pytest.raises(ParameterError, match=r"no co-occurrence rule '7<5'.*did you mean"):
        blend({"AU06": 1}, disabled={"7<5"})


def test_unilateral_aus_are_blended_per_side():
    res = blend({"AU06L": 1.0, "AU07": 0.8})
    assert res.aus == {"AU06L": 1.0, "AU07": 0.0, "AU07R": 0.8}
    assert res.trace[0].inputs == {"AU06L": 1.0, "AU07L": 0.8}
    both = blend({"AU06L": 1.0, "AU06R": 1.0, "AU07": 0.8})
    assert both.aus["AU07"] == 0.0 and "AU07L" not in both.aus
    one = blend({"AU12L": 1.0, "AU20L": 0.9, "AU20R": 0.9})
    assert one.aus == {"AU12L": 1.0, "AU20L": 0.0, "AU20R": 0.9}


def test_unknown_au_is_one_clear_error():
    with pytest.raises(ParameterError, match="unknown Action Unit 'AU03'"):
        blend({"AU03": 1.0})
    with pytest.raises(ParameterError, match=r"outside \[0, 1\]"):
        blend({"AU06": 1.5})


@pytest.mark.parametrize(("text", "msg"), [
    ("[domination]\n7<6\n7<\n", r"custom.txt:3: malformed rule '7<'"),
    ("[domination]\n16<12+18\n", r"custom.txt:2: .*combination rule .* under \[domination\]"),
    ("7<6\n7 < 6\n", r"custom.txt:2: rule 7<6 repeats line 1"),
    ("[nonsense]\n", r"custom.txt:1: unknown section"),
    ("7<99\n", r"custom.txt:1: .*unknown Action Unit"),
    ("[fuzzy]\nx small 0 0.5 0.2 1\n", r"custom.txt:2: fuzzy set breakpoints"),
    ("12@20Z\n", r"custom.txt:1: .*exclusion rules take plain AU numbers"),
])
def test_malformed_rules_file_names_the_line(tmp_path, text, msg):
    p = tmp_path / "custom.txt"
    p.write_text(text)
    with pytest.raises(DataError, match=msg):
        Blender.from_file(p)


def test_custom_rules_file_and_fuzzy_sets(tmp_path):
    p = tmp_path / "r.txt"
    p.write_text("# mine\n[fuzzy]\nz high 0.2 0.4 1 1\n[strong]\n12<15Z\n")
    b = Blender.from_file(p)
    assert b.blend({"AU15": 0.4, "AU12": 1.0}).aus["AU12"] == 0.0
    assert b.fuzzy["x"].points == (0.0, 0.0, 0.1, 0.4)  # default kept


def test_fuzzy_sets_partition_unity_and_mu_x_of_zero():
    f = Blender.default().fuzzy
    v = np.linspace(0, 1, 101)
    assert f["x"](0.0) == 1.0
    np.testing.assert_allclose(f["x"](v) + f["y"](v) + f["z"](v), 1.0)


def test_blend_frames_matches_blend_and_adds_side_channels(rng):
    chans = ["AU06L", "AU07", "AU12", "AU15", "AU51", "AU52"]
    vals = rng.random((50, len(chans))).astype(np.float32)
    out, out_ch = blend_frames(vals, chans)
    assert out_ch[: len(chans)] == tuple(chans) and "AU07R" in out_ch
    for i in (0, 17, 49):
        exp = blend(dict(zip(chans, vals[i].astype(float), strict=True))).aus
        got = dict(zip(out_ch, out[i].astype(float), strict=True))
        for k, v in exp.items():
            assert got.get(k, 0.0) == pytest.approx(v, abs=1e-5)


def test_blend_track_returns_a_track_with_counts():
    tr = AUTrack.from_frames([{"AU06": 1, "AU07": 0.8}, {"AU06": 0, "AU07": 0.8}], fps=25)
    out = blend_track(tr)
    assert isinstance(out, AUTrack) and out.fps == 25
    np.testing.assert_allclose(out["AU07"], [0.0, 0.8], atol=1e-6)
    assert out.meta["blender"] == {"7<6": 1}


AU_CODES = ["AU01", "AU02", "AU05", "AU06", "AU07", "AU09", "AU10", "AU12", "AU15", "AU16",
            "AU17", "AU18", "AU20", "AU22", "AU23", "AU24", "AU25", "AU26", "AU27", "AU28",
            "AU43", "AU51", "AU52", "AU61", "AU62", "AU63", "AU64"]
aus_st = st.dictionaries(st.sampled_from(AU_CODES), st.floats(0, 1), min_size=1, max_size=12)


@settings(max_examples=100, deadline=None)
@given(aus_st)
def test_outputs_in_range_and_never_raised(aus):
    out = blend(aus).aus
    for k, v in out.items():
        assert 0.0 <= v <= 1.0
        assert v <= aus.get(k, 0.0) + 1e-9  # no rule raises an activation


@settings(max_examples=100, deadline=None)
@given(st.sampled_from([r.notation for r in RULES if r.kind == "opposition"]),
       st.floats(0, 1), st.floats(0, 1))
def test_opposition_is_symmetric(rule, a, b):
    x, y = (code(int(n)) for n in rule.split("@"))
    one = Blender([Blender.default().rule(rule)])
    p, q = one.blend({x: a, y: b}).aus, one.blend({x: b, y: a}).aus
    assert p[x] == pytest.approx(q[y]) and p[y] == pytest.approx(q[x])


@settings(max_examples=100, deadline=None)
@given(aus_st, st.dictionaries(st.sampled_from(["AU04", "AU11", "AU13", "AU14", "AU45"]),
                               st.floats(0, 1), max_size=3))
def test_unrelated_aus_untouched(aus, extra):
    out = blend({**aus, **extra}).aus
    for k, v in extra.items():
        assert out[k] == v


@settings(max_examples=100, deadline=None)
@given(aus_st, st.sampled_from([r.notation for r in RULES]))
def test_disabled_rule_has_no_effect(aus, rule):
    b = Blender.default()
    without = Blender([r for r in b.rules if r.notation != rule], b.fuzzy)
    res = b.blend(aus, disabled={rule})
    assert res.aus == without.blend(aus).aus
    assert rule not in {t.rule for t in res.trace}


def test_docstring_examples_run():
    import doctest

    from mimika.facs import blender

    assert doctest.testmod(blender).failed == 0
