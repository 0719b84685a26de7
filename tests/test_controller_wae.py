"""The default controller (Wasserstein auto-encoder): a curved face manifold a PCA of the
same size cannot follow, and the shipped model's sliders."""

import numpy as np
import pytest

torch = pytest.importorskip("torch")

from mimika.learn.controller import Controller  # noqa: E402
from mimika.learn.wae import WAEConfig, train_wae, wae_state  # noqa: E402

K = 20


def ring(n, seed):
    """Frames on a curved 2-D manifold: each AU is a rectified cosine of one angle (each AU
    peaks at its own phase), scaled by an intensity — strong, sparse peaks."""
    rng = np.random.default_rng(seed)
    theta = rng.uniform(0, 2 * np.pi, n)
    r = rng.uniform(0.5, 1.0, n)
    phase = np.linspace(0, 2 * np.pi, K, endpoint=False)
    x = r[:, None] * np.maximum(np.cos(theta[:, None] - phase[None]), 0) ** 3
    return x.astype(np.float32), theta, r


def pca2(train, test):
    mu = train.mean(0)
    V = np.linalg.svd(train - mu, full_matrices=False)[2][:2]
    return np.clip(mu + (test - mu) @ V.T @ V, 0, 1)


@pytest.fixture(scope="module")
def ring_model():
    train, _, _ = ring(3000, 0)
    torch.set_num_threads(1)
    res = train_wae(train, WAEConfig(latent_dim=2, hidden=64, iters=1500, batch=128,
                                     knowledge=0.0))
    return train, Controller(wae_state(res, channels=tuple(f"AU{k:02d}" for k in range(K)),
                                       fps=30.0))


def test_wae_follows_a_curved_manifold_a_pca_cannot(ring_model):
    train, c = ring_model
    test = ring(300, 1)[0]
    rec = c.invert_batch(test, steps=100, restarts=2)[1]
    rmse = np.sqrt(np.mean((rec - test) ** 2))
    rmse_pca = np.sqrt(np.mean((pca2(train, test) - test) ** 2))
    assert rmse < 0.5 * rmse_pca
    peak = test >= 0.9 * test.max(axis=1, keepdims=True)  # each frame's strongest AU
    assert rec[peak].sum() / test[peak].sum() > 0.9  # strong AUs keep ≥ 90 %


def test_wae_starts_from_pca(ring_model):
    """Before training the decoder of encoded frames is the PCA reconstruction."""
    train, _ = ring_model
    res = train_wae(train, WAEConfig(latent_dim=2, hidden=16, iters=1, lr=1e-9))
    with torch.no_grad():
        x = torch.from_numpy(train[:50])
        rec = res.decoder(res.encoder(x)).clamp(0, 1).numpy()
    np.testing.assert_allclose(rec, pca2(train, train[:50]), atol=1e-4)


def test_prior_samples_cover_the_data(ring_model):
    """MMD: encoded training frames look like N(0, I), so slider settings land on faces."""
    train, c = ring_model
    z = c._enc(torch.from_numpy(train)).detach().numpy()
    assert np.all(np.abs(z.mean(0)) < 0.3) and np.all(np.abs(z.std(0) - 1) < 0.35)


@pytest.fixture(scope="module")
def shipped():
    return Controller.load()


def test_shipped_controller(shipped):
    c = shipped
    assert c.kind == "wae" and c.latent_dim == 6 and len(c.channels) == 20
    assert c.path.name == "controller.pt" and c.path.stat().st_size < 1_000_000
    z = np.random.default_rng(0).normal(0, 1, (100, 6))
    faces = c.generate(z)
    assert faces.min() >= 0 and faces.max() <= 1
    rec = c.invert_batch(faces[:20], steps=100, restarts=2)[1]
    spread = np.sqrt(np.mean((faces - faces.mean(0)) ** 2))  # the mean face's error
    assert np.sqrt(np.mean((rec - faces[:20]) ** 2)) < 0.2 * spread  # its own faces come back


def test_every_shipped_slider_changes_the_face_its_own_way(shipped):
    grid = shipped.traversal((-3.0, 0.0, 3.0))  # (d, 3, K)
    ends = np.concatenate([grid[:, 0], grid[:, 2]])  # 2d faces at the slider ends
    move = np.abs(ends - np.concatenate([grid[:, 1], grid[:, 1]])).max(axis=1)
    # every end moves some AU by ≥ 0.4 from the middle face (the shipped sliders are turned
    # for distinct ends: the weakest moves an AU by 0.45; unturned, by 0.29)
    assert np.all(move > 0.4)
    d = np.abs(ends[:, None] - ends[None]).max(axis=2)
    np.fill_diagonal(d, 1.0)
    assert d.min() > 0.4  # no two slider ends give the same face (shipped: 0.46)


def test_turning_the_sliders_keeps_the_model_and_separates_the_ends(ring_model):
    """A rotated latent space is the same WAE (prior N(0, I)): G'(z) = G(R·z), E' = Rᵀ·E;
    the rotation chosen makes the weakest slider end stronger."""
    from mimika.learn.sliders import distinct_rotation, distinctness, rotate_state

    train, c = ring_model
    state = {"kind": "wae", "config": c.config, "channels": c.channels, "fps": c.fps,
             "mean": c.mean, "std": c.std, "generator": c._g.state_dict(),
             "encoder": c._enc.state_dict()}
    r = distinct_rotation(c, steps=150)
    assert np.allclose(r @ r.T, np.eye(2), atol=1e-5)
    turned = Controller(rotate_state(state, r))
    z = np.random.default_rng(0).standard_normal((50, 2)).astype(np.float32)
    np.testing.assert_allclose(turned.generate(z), c.generate(z @ r.T), atol=1e-5)
    with torch.no_grad():
        x = torch.from_numpy(train[:50])
        np.testing.assert_allclose(turned._enc(x).numpy(), c._enc(x).numpy() @ r, atol=1e-5)
    before = distinctness(c, torch.eye(2))[1]
    after = distinctness(turned, torch.eye(2))[1]
    assert after >= before - 1e-6


def test_shipped_names():
    from mimika.errors import ParameterError

    assert Controller.load("seed").kind == "wgan"
    assert Controller.load(conditional=True).kind == "cgan"
    with pytest.raises(ParameterError, match="shipped"):
        from mimika.learn.controller import shipped_model

        shipped_model(name="nope")


def test_facs_frames_show_every_au_alone_and_obey_the_rules():
    from mimika.facs.blender import blend_frames
    from mimika.learn.data import MODEL_CHANNELS
    from mimika.learn.facs_frames import facs_frames

    x = facs_frames()
    assert x.shape == (3000, len(MODEL_CHANNELS)) and x.min() >= 0 and x.max() <= 1
    np.testing.assert_array_equal(x, facs_frames())  # deterministic
    for k in range(len(MODEL_CHANNELS)):  # each AU strong with every other AU near rest
        others = np.delete(x, k, axis=1)
        assert np.any((x[:, k] > 0.7) & (others.max(axis=1) < 0.1)), MODEL_CHANNELS[k]
    # mixes went through the AU Blender: blending again changes nothing beyond the jitter
    again = blend_frames(x, MODEL_CHANNELS)[0][:, :len(MODEL_CHANNELS)]
    assert np.abs(again - x).max() < 0.1
    smile, stretch = MODEL_CHANNELS.index("AU12"), MODEL_CHANNELS.index("AU20")
    assert not np.any((x[:, smile] > 0.5) & (x[:, stretch] > 0.5))  # 12 excludes 20
    # given recorded frames, a quarter are one of them with one more AU
    base = np.full((5, len(MODEL_CHANNELS)), 0.05, np.float32)
    more = facs_frames(400, base=base)[-100:]
    assert np.all(np.sum(more > 0.15, axis=1) == 1) and np.all(np.sort(more)[:, :-1] <= 0.05)


def test_facs_frames_teach_an_action_the_recordings_never_show():
    """Recordings without AU24 (lip press): trained on them alone, the sliders cannot make a
    lip press; with a share of FACS frames in each batch they can."""
    from mimika.learn.data import MODEL_CHANNELS

    k = MODEL_CHANNELS.index("AU24")
    train = ring(3000, 0)[0]
    train[:, k] = 0.0
    press = np.zeros((10, K), np.float32)
    press[:, k] = np.linspace(0.6, 0.9, 10)
    torch.set_num_threads(1)
    kept = {}
    for share in (0.0, 0.3):
        res = train_wae(train, WAEConfig(latent_dim=4, hidden=64, iters=1500, batch=128,
                                         knowledge=share))
        c = Controller(wae_state(res, channels=MODEL_CHANNELS, fps=30.0))
        rec = c.invert_batch(press, steps=100, restarts=2)[1]
        kept[share] = rec[:, k].sum() / press[:, k].sum()
    assert kept[0.0] < 0.1 and kept[0.3] > 0.4, kept


def test_inversion_weighted_like_training_keeps_the_strong_au():
    """A generator that can only move two AUs together, a frame with one strong and one weak
    AU: plain least squares meets in the middle (0.5), the WAE's weighting 1 + 4·x keeps more
    of the strong one — as the shipped controller inverts."""
    from mimika.learn.inversion import invert_frames

    def gen(z, y=None):
        return z[:, :1] * torch.ones(1, 2)

    x = np.array([[0.8, 0.2]], np.float32)
    kept = {p: invert_frames(gen, x, np.zeros(2), np.ones(2), latent_dim=1, prior=0.0,
                             steps=300, restarts=1, peak=p)[1][0, 0] for p in (0.0, 4.0)}
    assert abs(kept[0.0] - 0.5) < 0.01
    assert abs(kept[4.0] - (4.2 * 0.8 + 1.8 * 0.2) / 6.0) < 0.01
