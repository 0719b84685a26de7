"""Transition metrics and interpolation baselines against hand-computed values."""

import numpy as np
import pytest

from mimika.learn import metrics as M
from mimika.learn.baselines import cosine, hermite, linear


def test_mse_l2_jump_endpoint_by_hand():
    window = np.array([[0.0, 0.0], [0.1, 0.2]])
    gen = np.array([[0.2, 0.2], [0.5, 0.6]])
    gt = np.array([[0.1, 0.2], [0.5, 0.8]])
    assert M.mse(gen, gt) == pytest.approx((0.01 + 0 + 0 + 0.04) / 4)
    assert M.l2(gen, gt) == pytest.approx((0.1 + 0.2) / 2)
    # first generated vs last seed frame: |0.2-0.1|, |0.2-0.2| → mean 0.05 → 5 %
    assert M.jump_percent(window, gen) == pytest.approx(5.0)
    assert M.endpoint_error(gen, gt[-1]) == pytest.approx((0.0 + 0.2) / 2)


def test_reactivation_counts_a_second_rise_only():
    up = np.linspace(0, 0.8, 10)[:, None]  # a legitimate rise to the target
    assert M.reactivation(up)[0] == pytest.approx(0.0)
    dip = np.array([0.6, 0.3, 0.0, 0.35, 0.1, 0.0])[:, None]  # falls, rises 0.35, falls
    assert M.reactivation(dip)[0] == pytest.approx(0.35)


def test_conspicuous_criteria():
    w = np.zeros((20, 3))
    calm = np.linspace(0, 0.5, 10)[:, None].repeat(3, 1)
    c = M.conspicuous(w, calm, calm)
    assert not c.any
    big = calm.copy()
    big[0, 0] = 0.45  # one step > 40 %
    assert M.conspicuous(w, big, calm).jumps
    three = calm.copy()
    three[0] = 0.25  # three AUs step > 20 %
    assert M.conspicuous(w, three, calm).jumps
    far = calm.copy()
    far[-1, 1] = 0.0  # end 0.5 away from the target
    c = M.conspicuous(w, far, calm)
    assert c.endpoint and c.any
    off = calm + 0.0
    off[5, 2] = 0.95  # far from GT (> 1.00/1.20) is impossible in [0, 1] unless 0.95 vs 0.1
    gt = calm.copy()
    gt[5, 2] = 0.05
    assert M.conspicuous(w, off, gt).gt_diff


def test_summarise_pools_mse_and_counts():
    w = [np.zeros((20, 1)), np.zeros((20, 1))]
    gens = [np.full((2, 1), 0.1), np.full((4, 1), 0.0)]
    gts = [np.zeros((2, 1)), np.zeros((4, 1))]
    s = M.summarise(w, gens, gts)
    assert s["n"] == 2
    assert s["mse"] == pytest.approx(2 * 0.01 / 6)
    assert s["jump_pct"] == pytest.approx(5.0)
    assert s["conspicuous"] == 0


@pytest.mark.parametrize("f", [linear, cosine, hermite])
def test_baselines_end_on_the_target(f):
    w = np.array([[0.0, 0.5], [0.1, 0.5]])
    b = np.array([0.9, 0.0])
    out = f(w, b, 12)
    assert out.shape == (12, 2)
    np.testing.assert_allclose(out[-1], b, atol=1e-6)


def test_linear_and_hermite_by_hand():
    w = np.array([[0.0], [0.1]])
    np.testing.assert_allclose(linear(w, np.array([0.5]), 4)[:, 0], [0.2, 0.3, 0.4, 0.5])
    # Hermite with start velocity 0.1/frame over L=2: u=0.5 → 0.5·a + 0.125·2·0.1 + 0.5·b
    assert hermite(w, np.array([0.5]), 2)[0, 0] == pytest.approx(0.05 + 0.025 + 0.25)
    assert cosine(w, np.array([0.5]), 2)[0, 0] == pytest.approx(0.3)
