"""Gap filling for seed 000's augmentation: linear / quadratic / cubic Lagrange (io.tracks)."""

import numpy as np
import pytest

from mimika.errors import ParameterError
from mimika.io.tracks import fill_gaps


def _poly(t, coeffs):
    return sum(c * t**i for i, c in enumerate(coeffs))


@pytest.mark.parametrize(("method", "coeffs"), [
    ("linear", [0.2, 0.01]),
    ("quadratic", [0.1, 0.02, -0.0007]),
    ("cubic", [0.3, -0.01, 0.0009, -0.00002]),
])
def test_polynomial_recovered_exactly_by_its_degree(method, coeffs):
    t = np.arange(60, dtype=np.float64)
    truth = np.stack([_poly(t, coeffs), _poly(t, coeffs[::-1]) * 0.01], axis=1)
    ok = np.ones(60, bool)
    ok[[3, 10, 11, 12, 30, 31, 32, 33, 34, 50]] = False  # single and multi-frame gaps
    noisy = truth.copy()
    noisy[~ok] = 9.0  # garbage where the drop-outs are
    out = fill_gaps(noisy, ok, method=method)
    np.testing.assert_allclose(out, truth.astype(np.float32), rtol=1e-5, atol=1e-5)


def test_cubic_is_not_exact_for_quadratic_method_and_vice_versa():
    t = np.arange(40, dtype=np.float64)
    cubic = (0.001 * (t - 20) ** 3)[:, None]
    ok = np.ones(40, bool)
    ok[18:23] = False
    q = fill_gaps(cubic, ok, method="quadratic")
    c = fill_gaps(cubic, ok, method="cubic")
    assert np.max(np.abs(q - cubic)) > 1e-3
    np.testing.assert_allclose(c, cubic, atol=1e-5)


def test_edges_are_held_and_valid_rows_untouched():
    v = np.arange(10, dtype=np.float64)[:, None] ** 2
    ok = np.ones(10, bool)
    ok[[0, 1, 9]] = False
    out = fill_gaps(v, ok, method="cubic")
    assert out[0, 0] == out[1, 0] == 4.0
    assert out[9, 0] == 64.0
    np.testing.assert_array_equal(out[ok], v[ok].astype(np.float32))


def test_too_few_valid_rows_fall_back_to_linear():
    v = np.array([[0.0], [5.0], [1.0]])
    out = fill_gaps(v, np.array([True, False, True]), method="cubic")
    assert out[1, 0] == pytest.approx(0.5)


def test_unknown_method_names_the_choices():
    with pytest.raises(ParameterError, match="quadratic, cubic"):
        fill_gaps(np.zeros((3, 1)), np.array([True, False, True]), method="spline")
