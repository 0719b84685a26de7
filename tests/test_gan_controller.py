"""The shipped controllers: loading, sampling (clamped + blended), traversal grids, inversion."""

import numpy as np
import pytest

torch = pytest.importorskip("torch")

from mimika.errors import ParameterError  # noqa: E402
from mimika.learn.controller import TRAVERSAL, Controller  # noqa: E402


@pytest.fixture(scope="module")
def gan():
    return Controller.load("seed")


@pytest.fixture(scope="module")
def cgan():
    return Controller.load(conditional=True)


def test_shipped_models_load_and_are_small(gan, cgan):
    assert gan.kind == "wgan" and gan.latent_dim == 4 and gan.labels == ()
    assert cgan.kind == "cgan" and "surprise" in cgan.labels and "neutral" in cgan.labels
    for c in (gan, cgan):
        assert len(c.channels) == 20 and c.fps == 30.0
        assert c.path.stat().st_size < 1_000_000
        assert c.meta["test_takes"] == ["apfel"] and "apfel" not in c.meta["train_takes"]


def test_samples_in_range_and_blended(gan, cgan):
    from mimika.facs.blender import blend_frames

    z = np.random.default_rng(0).normal(0, 2, (200, 4))
    for c, lab in ((gan, None), (cgan, "surprise")):
        raw = c.generate(z, lab)
        assert raw.shape == (200, 20) and raw.min() >= 0 and raw.max() <= 1
        aus = c.sample(z[0], label=lab)
        vals, chans = blend_frames(raw[:1], c.channels)
        expect = {ch: float(v) for ch, v in zip(chans, vals[0], strict=True)}
        assert aus.keys() == expect.keys()
        assert all(abs(aus[k] - expect[k]) < 1e-5 for k in aus)
        assert all(0 <= v <= 1 for v in aus.values())


def test_label_changes_the_face(cgan):
    z = np.zeros(4)
    smile = cgan.sample(z, label="happiness")
    wow = cgan.sample(z, label="surprise")
    assert smile["AU12"] > wow["AU12"]
    assert wow["AU01"] + wow["AU02"] > smile["AU01"] + smile["AU02"]


def test_errors(gan, cgan):
    with pytest.raises(ParameterError, match="3 value"):
        gan.sample([0, 0, 0])
    with pytest.raises(ParameterError, match="unconditional"):
        gan.sample([0, 0, 0, 0], label="surprise")
    with pytest.raises(ParameterError, match="did you mean 'surprise'"):
        cgan.sample([0, 0, 0, 0], label="suprise")


def test_traversal_shape(gan):
    t = gan.traversal()
    assert t.shape == (4, len(TRAVERSAL), 20)
    assert np.allclose(t[0, 3], t[1, 3])  # the 0 column is the same face in every row


@pytest.mark.render
def test_traversal_grid_tiles(gan, monkeypatch):
    import mimika.render as render

    seen = {}
    real = render.contact_sheet

    def spy(images, labels, columns, title):
        seen.update(n=len(images), columns=columns, labels=labels, shape=images[0].shape)
        return real(images, labels, columns=columns, title=title)

    monkeypatch.setattr(render, "contact_sheet", spy)
    img = gan.render_grid(tile=(32, 32), values=(-3, 0, 3))
    assert seen["n"] == 4 * 3 and seen["columns"] == 3 and seen["shape"] == (32, 32, 3)
    assert seen["labels"][:3] == ["z1=-3", "z1=+0", "z1=+3"]
    assert img.dtype == np.uint8 and img.shape[1] >= 3 * 32


def test_inversion_recovers_generated_faces(gan, cgan):
    for c, lab in ((gan, None), (cgan, "happiness")):
        _, x = c.random(8, label=lab, seed=5)
        zh, rec = c.invert_batch(x, None if lab is None else [lab] * 8, steps=150)
        assert zh.shape == (8, 4)
        assert np.sqrt(np.mean((rec - x) ** 2)) < 0.02
    one = gan.invert(gan.generate([0.5, -1.0, 1.0, 0.0])[0])
    assert one.shape == (4,)
    assert np.abs(gan.generate(one) - gan.generate([0.5, -1.0, 1.0, 0.0])).max() < 0.05
