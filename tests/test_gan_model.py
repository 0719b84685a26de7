"""Seed 001's WGAN: shapes, the hand-written critic step, clipping, training, checkpoints."""

import numpy as np
import pytest

torch = pytest.importorskip("torch")

from mimika.errors import DataError, ParameterError  # noqa: E402
from mimika.learn.wgan import (  # noqa: E402
    Critic,
    Generator,
    Normaliser,
    WGANConfig,
    _CriticTrainer,
    load_checkpoint,
    save_checkpoint,
    train_wgan,
    wgan_state,
)


@pytest.fixture(autouse=True, scope="module")
def one_thread():
    n = torch.get_num_threads()
    torch.set_num_threads(1)
    yield
    torch.set_num_threads(n)


CHANNELS = ("AU01", "AU02", "AU04", "AU06", "AU12", "AU27")


def synthetic(rng, n=400):
    """Two expressions (brows up / smile + jaw) with noise, in [0, 1]: (n, 6)."""
    a = np.array([0.6, 0.5, 0.0, 0.0, 0.0, 0.1])
    b = np.array([0.0, 0.0, 0.1, 0.5, 0.8, 0.3])
    w = rng.uniform(0, 1, (n, 1))
    x = w * a + (1 - w) * b + rng.normal(0, 0.03, (n, 6))
    return np.clip(x, 0, 1).astype(np.float32)


def test_shapes():
    g = Generator(4, 20)
    c = Critic(20)
    z = torch.randn(7, 4)
    assert g(z).shape == (7, 20)
    assert c(g(z)).shape == (7, 1)
    assert c.W1.shape == (64, 20) and c.w2.shape == (64, 1)
    assert sum(p.numel() for p in c.parameters()) == 64 * 20 + 64 + 64 + 1


def test_manual_critic_gradient_matches_autograd():
    cfg = WGANConfig(batch=8)
    c = Critic(6, hidden=16, seed=3)
    tr = _CriticTrainer(c, cfg)
    real, fake = torch.randn(8, 6), torch.randn(8, 6)
    tr.gradient(real, fake)
    loss = c(fake).mean() - c(real).mean()
    (g,) = torch.autograd.grad(loss, c.flat)
    assert torch.allclose(tr.g, g, atol=1e-6)


def test_critic_weights_stay_clipped_and_w_moves(rng):
    x = synthetic(rng)
    res = train_wgan(x[:300], x[300:], WGANConfig(latent_dim=2, n_critic=5, iters=60, seed=1))
    flat = res.critic.flat.detach()
    assert float(flat.abs().max()) <= 0.01 + 1e-9
    assert res.w_train.shape == res.w_test.shape == (60,)
    assert np.all(np.isfinite(res.w_train)) and np.all(np.isfinite(res.w_test))
    # the critic learns to separate real from generated: the estimate rises off ~0
    assert res.w_train[-10:].mean() > res.w_train[:3].mean() + 1e-4


def test_config_and_input_validation(rng):
    with pytest.raises(ParameterError, match="n_critic=0"):
        WGANConfig(n_critic=0).check()
    with pytest.raises(ParameterError, match="shape"):
        train_wgan(np.zeros((0, 3)), config=WGANConfig(iters=1))
    bad = synthetic(rng, 10)
    bad[0, 0] = np.nan
    with pytest.raises(ParameterError, match="NaN"):
        train_wgan(bad, config=WGANConfig(iters=1))


def test_normaliser_roundtrip(rng):
    x = synthetic(rng)
    n = Normaliser.fit(x)
    assert np.allclose(n.inverse(n.forward(x)), x, atol=1e-5)
    assert np.allclose(n.forward(x).mean(0), 0, atol=1e-4)


def test_checkpoint_roundtrip_and_controller(tmp_path, rng):
    from mimika.facs.blender import blend_frames
    from mimika.learn.controller import Controller

    x = synthetic(rng)
    res = train_wgan(x, None, WGANConfig(latent_dim=3, n_critic=2, iters=20))
    state = wgan_state(res, channels=CHANNELS, fps=30.0, meta={"test": True})
    p = save_checkpoint(tmp_path / "g.pt", state)
    st = load_checkpoint(p)
    assert st["kind"] == "wgan" and st["channels"] == list(CHANNELS) and st["fps"] == 30.0
    assert st["config"]["n_critic"] == 2 and np.allclose(st["mean"], res.normaliser.mean)
    c = Controller.load(p)
    assert c.latent_dim == 3 and c.labels == () and c.channels == CHANNELS
    raw = c.generate(np.random.default_rng(0).normal(0, 3, (50, 3)))
    assert raw.shape == (50, 6) and raw.min() >= 0 and raw.max() <= 1
    aus = c.sample([3.0, -3.0, 3.0])
    assert all(0 <= v <= 1 for v in aus.values())
    blended, chans = blend_frames(c.generate([[3.0, -3.0, 3.0]]), CHANNELS)
    assert aus == {ch: round(float(v), 6) for ch, v in zip(chans, blended[0], strict=True)}


def test_bad_checkpoints(tmp_path):
    with pytest.raises(DataError, match="does not exist"):
        load_checkpoint(tmp_path / "missing.pt")
    junk = tmp_path / "junk.pt"
    junk.write_bytes(b"not a checkpoint")
    with pytest.raises(DataError, match="not a mimika GAN checkpoint"):
        load_checkpoint(junk)


def test_conditional_model_generates_the_asked_label(rng):
    from mimika.learn.cgan import CGANConfig, train_cgan

    # two labels in overlapping halves of the same expression continuum
    a = np.array([0.6, 0.5, 0.0, 0.0, 0.0, 0.1])
    b = np.array([0.0, 0.0, 0.1, 0.5, 0.8, 0.3])
    w = rng.uniform(0, 1, (600, 1))
    x = np.clip(w * a + (1 - w) * b + rng.normal(0, 0.05, (600, 6)), 0, 1).astype(np.float32)
    y = (w[:, 0] > 0.5).astype(np.int64)  # 1: nearer the brows-up end
    res = train_cgan(x, y, ("smile", "brows"),
                     config=CGANConfig(iters=300, hidden=32, lr=1e-3, eval_batch=32))
    centres = np.stack([x[y == k].mean(0) for k in (0, 1)])
    for k in (0, 1):
        with torch.no_grad():
            g = res.generator(torch.randn(500, 4), torch.full((500,), k))
        f = res.normaliser.inverse(g.numpy())
        found = np.linalg.norm(f[:, None] - centres[None], axis=2).argmin(1)
        assert np.mean(found == k) > 0.98  # without the auxiliary classifier: ≈ 0.97
    with pytest.raises(ParameterError, match="classifier"):
        CGANConfig(classifier=-1).check()
