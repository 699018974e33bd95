"""The safeguarded Newton ascent (core.ascent) on functions with known maxima.

``_trust_region_step`` must return the maximiser of the quadratic model in the ball
(checked against a dense search on the circle and the Newton step inside it);
``newton_ascent`` must reach the maximum of a smooth function from inside its concave
region, and stay put where no step gains. The matched filter's Newton fit is compared
with a tight Nelder-Mead on the same ``|I|`` in ``tests/motion/test_likelihood_fit.py``.
"""

from __future__ import annotations

import numpy as np
import pytest

from sarmotion.core.ascent import _trust_region_step, newton_ascent


def _model(g, b, z):
    return g @ z - 0.5 * z @ b @ z


@pytest.mark.parametrize("seed", range(6))
def test_trust_region_step_maximises_the_model_in_the_ball(seed):
    rng = np.random.default_rng(seed)
    a = rng.standard_normal((2, 2))
    b = a @ a.T + (rng.uniform(-2.0, 2.0)) * np.eye(2)  # definite or indefinite
    g = rng.standard_normal(2)
    radius = rng.uniform(0.1, 2.0)
    z = _trust_region_step(g, b, radius)
    assert np.linalg.norm(z) <= radius * (1 + 1e-9)
    angles = np.linspace(0.0, 2 * np.pi, 20001)
    circle = radius * np.stack([np.cos(angles), np.sin(angles)], axis=1)
    best = max(_model(g, b, c) for c in circle)
    if np.all(np.linalg.eigvalsh(b) > 0):
        newton = np.linalg.solve(b, g)
        if np.linalg.norm(newton) <= radius:
            best = max(best, _model(g, b, newton))
    assert _model(g, b, z) >= best - 1e-6 * (1 + abs(best))


def _gaussian(centre, widths):
    centre = np.asarray(centre, dtype=float)
    inv = np.diag(1.0 / np.asarray(widths, dtype=float) ** 2)

    def evaluate(x):
        d = x - centre
        value = np.exp(-0.5 * d @ inv @ d)  # |I| of a Gaussian lobe; |I|^2 below
        f = value**2
        grad = -2.0 * f * (inv @ d)
        hess = f * (4.0 * np.outer(inv @ d, inv @ d) - 2.0 * inv)
        return f, grad, hess, complex(value)

    return evaluate


def test_ascent_reaches_the_peak_in_anisotropic_units():
    """A lobe 1 mm wide in one parameter and 1 m/s in the other, start inside it."""
    evaluate = _gaussian([0.002, 3.0], [1e-3, 1.0])
    x, value, moved, n = newton_ascent(
        evaluate,
        np.array([0.0027, 3.6]),
        radius=1.0,
        tol=1e-3,
        max_iter=50,
        scale=np.array([1e-3, 1.0]),
    )
    assert moved
    np.testing.assert_allclose(x, [0.002, 3.0], atol=1e-8)
    assert abs(value) == pytest.approx(1.0, abs=1e-12)
    assert n <= 12


def test_ascent_stays_at_a_maximum():
    evaluate = _gaussian([1.0, -2.0], [0.5, 0.5])
    x, value, moved, _ = newton_ascent(
        evaluate, np.array([1.0, -2.0]), radius=0.1, tol=1e-4, max_iter=20
    )
    assert not moved
    np.testing.assert_array_equal(x, [1.0, -2.0])
