"""Timeline contracts: easing endpoints, chaining without neutral dips, channels, sync."""

import math

import numpy as np
import pytest

from mimika.errors import MimikaError, ParameterError
from mimika.timeline import (
    Channel,
    Event,
    Timeline,
    easing_names,
    get_interpolator,
    register_easing,
    register_interpolator,
    sample,
    synchronise,
    timeline_from_events,
    values_at,
)


def expr(name, start, dur, **kw):
    return Event("expression", start, dur, name=name, **kw)


@pytest.mark.parametrize("name", ["linear", "cosine", "smoothstep"])
def test_easing_hits_endpoints_and_is_monotone(name):
    f = get_interpolator(name)
    u = np.linspace(0, 1, 101)
    y = f(np.array([0.2]), np.array([0.9]), u, channels=("AU12",), duration=1.0)[:, 0]
    assert y[0] == pytest.approx(0.2) and y[-1] == pytest.approx(0.9)
    assert np.all(np.diff(y) >= -1e-7)


def test_register_easing_and_interpolator_hook():
    register_easing("quad-test", lambda u: u * u, replace=True)
    assert "quad-test" in easing_names()
    with pytest.raises(ParameterError, match="0 → 0 and 1 → 1"):
        register_easing("bad-test", lambda u: u * 0.5)

    class Learned:  # what the LSTM transition model plugs in as
        def __call__(self, a, b, u, *, channels, duration):
            return (a[None] + (b - a)[None] * np.sqrt(u)[:, None]).astype(np.float32)

    register_interpolator("learned-test", Learned(), replace=True)
    tl = timeline_from_events([expr("happiness", 0, 2, ease="learned-test")])
    tr = sample(tl, fps=50)
    assert tr["AU12"].max() == pytest.approx(1.0)
    with pytest.raises(ParameterError, match="did you mean"):
        Event("blink", 0, 0.3, name="both", ease="cosin")


def test_consecutive_expressions_do_not_dip_to_neutral():
    # happiness then sadness with a gap: AU12 falls while AU15 rises, the face never goes
    # neutral in between (seed 002 §5.4); neutral only at the very start and end
    tl = timeline_from_events([expr("happiness", 0.5, 1.5), expr("sadness", 2.5, 1.5)])
    tr = sample(tl, fps=100)
    t = tr.times
    total = tr.values.sum(axis=1)
    inside = (t > 0.5 + 0.3) & (t < 4.0 - 0.4)
    assert total[inside].min() > 0.5
    assert total[0] == 0 and total[-1] == pytest.approx(0, abs=1e-6)
    # with a bridge shorter than the gap the face does return to neutral
    ch = Channel("face", tl.channel("face").events, bridge=0.2)
    tr2 = sample(tl.with_channels([ch]), fps=100)
    assert tr2.values.sum(axis=1)[(t > 2.05) & (t < 2.45)].max() == pytest.approx(0, abs=1e-6)


def test_onset_apex_offset_and_intensity():
    e = expr("happiness", 1.0, 2.0, onset=0.5, offset=0.5, intensity=0.5)
    tl = timeline_from_events([e])
    assert values_at(tl, 0.99)["AU12"] == 0
    assert values_at(tl, 1.25)["AU12"] == pytest.approx(0.25, abs=1e-6)  # cosine midpoint
    assert values_at(tl, 2.0)["AU12"] == pytest.approx(0.5)  # AU12 at E × 0.5
    assert values_at(tl, 3.0)["AU12"] == pytest.approx(0.0, abs=1e-6)


def test_channels_add_clip_and_override():
    a = Event("aus", 0, 2, aus=(("AU12", 0.7),), onset=0.5, offset=0.5)
    b = Event("aus", 0, 2, aus=(("AU12", 0.6),), onset=0.5, offset=0.5)
    tl = Timeline((Channel("a", (a,)), Channel("b", (b,))))
    assert values_at(tl, 1.0)["AU12"] == 1.0  # 1.3 clipped
    tl2 = Timeline((Channel("a", (a,)), Channel("b", (b,), override=True)))
    assert values_at(tl2, 1.0)["AU12"] == pytest.approx(0.6)


def test_overlap_and_negative_times_are_clear_errors():
    with pytest.raises(ParameterError, match="overlaps"):
        timeline_from_events([expr("happiness", 0, 2), expr("sadness", 1, 1)])
    with pytest.raises(ParameterError, match="negative"):
        expr("happiness", -1, 1)
    with pytest.raises(ParameterError, match="> 0"):
        expr("happiness", 0, 0)
    with pytest.raises(ParameterError, match="do not fit"):
        expr("happiness", 0, 1, onset=0.8, offset=0.8)
    with pytest.raises(MimikaError, match="unknown expression"):
        sample(timeline_from_events([expr("hapiness", 0, 1)]), fps=25)


def test_gestures_blink_gaze_and_sampling_any_fps():
    tl = timeline_from_events([Event("blink", 0.5, 0.3, name="both"),
                               Event("nod", 1.0, 0.6, count=2),
                               Event("shake", 2.0, 0.8),
                               Event("gaze", 3.0, 1.0, name="up-left")])
    for fps in (12.5, 30, 60):
        tr = sample(tl, fps=fps)
        assert tr.fps == fps and tr.n_frames == math.ceil(4.0 * fps) + 1
    tr = sample(tl, fps=100)
    assert tr["AU45"].max() == 1.0
    assert tr["AU54"].max() > 0.3 and tr["AU51"].max() > 0.2 and tr["AU52"].max() > 0.2
    assert values_at(tl, 3.5)["AU61"] == 1.0 and values_at(tl, 3.5)["AU63"] == 1.0


def test_sampler_blend_flag_runs_the_au_blender():
    tl = timeline_from_events([Event("aus", 0, 1, aus=(("AU06", 1.0), ("AU07", 1.0)),
                                     onset=0.1, offset=0.1)])
    plain = sample(tl, fps=25)
    blended = sample(tl, fps=25, blend=True)
    assert "blender" in blended.meta
    assert blended.values.shape[0] == plain.values.shape[0]


def test_synchroniser_clamps_and_warns():
    tl = timeline_from_events([expr("template/astonishment", 1.0, 5.0)])
    warn = synchronise(tl)
    assert any(f.rule == "timing.possible" and f.level == "error" for f in warn.findings)
    assert warn.timeline == tl
    clamp = synchronise(tl, mode="clamp")
    assert clamp.timeline.channel("face").events[0].duration == pytest.approx(2.0)
    with pytest.raises(ParameterError, match=r"Table 6\.15"):
        synchronise(tl, mode="error")
    acc = synchronise(tl, accept=True)
    assert any(c.name == "knowledge" for c in acc.timeline.channels)
