"""Spoken clips in batch specs: ``animation: {speech: …, audio: …}`` lip-syncs each clip."""

import numpy as np
import pytest

from mimika.batch import load_spec, make_plan
from mimika.batch.spec import SpecError
from mimika.speech.audio import write_wav


def _spec(tmp_path, body: str):
    p = tmp_path / "spec.yaml"
    p.write_text(body)
    return load_spec(p)


def test_speech_and_audio_keys_are_checked(tmp_path):
    with pytest.raises(SpecError, match="audio needs speech"):
        _spec(tmp_path, "aus: [AU12]\nanimation: {audio: a.wav}\n")
    with pytest.raises(SpecError, match="does not exist"):
        _spec(tmp_path, "aus: [AU12]\nanimation: {speech: Hello, audio: missing.wav}\n")
    with pytest.raises(SpecError, match="unknown language"):
        _spec(tmp_path, "aus: [AU12]\nanimation: {speech: Hello, lang: xx-nope}\n")


@pytest.mark.render
def test_a_spoken_clip_carries_the_recording_and_moves_the_lips(tmp_path):
    import av

    from mimika.batch.worker import render_items
    from mimika.speech import synthesize

    rec = synthesize("Bob bought a big map.", voice="f3", rate=150)
    write_wav(tmp_path / "bob.wav", rec.audio, sr=rec.sr)
    spec = _spec(tmp_path, "aus: [AU12]\nsize: 64x48\nsamples: 0\nanimation: {speech: Bob "
                           "bought a big map., audio: bob.wav, fps: 25, format: mp4}\n")
    plan = make_plan(spec)
    [res] = render_items([plan.items[0].payload()], plan.settings())
    assert res["ok"], res.get("error")
    clip = tmp_path / "clip.mp4"
    clip.write_bytes(res["clip"])
    with av.open(str(clip)) as c:
        a = c.streams.audio[0]
        assert float(a.duration * a.time_base) == pytest.approx(rec.duration, abs=0.01)
        frames = [f.to_ndarray(format="gray").astype(float) for f in c.decode(video=0)]
    assert len(frames) == pytest.approx(rec.duration * 25, abs=1.5)
    mouth = np.array([f[30:44, 22:42].mean() for f in frames])  # the lower face moves
    assert mouth.std() > 0.5
