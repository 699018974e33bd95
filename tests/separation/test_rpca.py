"""Tests of sarmotion.separation.rpca: principal component pursuit (IALM), plain and windowed."""

from __future__ import annotations

import numpy as np
import pytest

from sarmotion.separation import (
    RPCAResult,
    choose_window,
    default_eta,
    rpca,
    singular_value_threshold,
    soft_threshold,
    window_bounds,
    window_weights,
    windowed_rpca,
)


def low_rank_plus_sparse(
    rng: np.random.Generator,
    n: int,
    m: int,
    *,
    rank: int,
    density: float = 0.05,
    amplitude: float = 10.0,
    complex_: bool = True,
) -> tuple[np.ndarray, np.ndarray]:
    """``L`` of the given rank with O(1) entries, ``S`` with random support and phases."""
    if complex_:
        u = rng.standard_normal((n, rank)) + 1j * rng.standard_normal((n, rank))
        v = rng.standard_normal((rank, m)) + 1j * rng.standard_normal((rank, m))
        low = u @ v / np.sqrt(2 * rank)
    else:
        low = rng.standard_normal((n, rank)) @ rng.standard_normal((rank, m)) / np.sqrt(rank)
    support = rng.random((n, m)) < density
    sparse = np.zeros_like(low)
    if complex_:
        sparse[support] = amplitude * np.exp(2j * np.pi * rng.random(support.sum()))
    else:
        sparse[support] = amplitude * rng.choice([-1.0, 1.0], support.sum())
    return low, sparse


def column_blocks(
    rng: np.random.Generator, n: int, n_blocks: int, width: int, rank: int
) -> tuple[np.ndarray, np.ndarray]:
    """Columns in blocks of ``width``, each block rank ``rank`` in its own random subspace,
    plus 5 % unit-modulus-times-5 spikes: globally rank ``n_blocks * rank``."""
    blocks = []
    for _ in range(n_blocks):
        u = rng.standard_normal((n, rank)) + 1j * rng.standard_normal((n, rank))
        v = rng.standard_normal((rank, width)) + 1j * rng.standard_normal((rank, width))
        blocks.append(u @ v / np.sqrt(2 * rank))
    low = np.hstack(blocks)
    support = rng.random(low.shape) < 0.05
    sparse = np.zeros_like(low)
    sparse[support] = 5.0 * np.exp(2j * np.pi * rng.random(support.sum()))
    return low, sparse


def rel(a: np.ndarray, b: np.ndarray) -> float:
    return float(np.linalg.norm(a - b) / np.linalg.norm(b))


# --------------------------------------------------------------------------------------
# proximal operators
# --------------------------------------------------------------------------------------
def test_soft_threshold_shrinks_modulus_and_keeps_phase():
    rng = np.random.default_rng(1)
    modulus = rng.uniform(0.0, 3.0, 500)
    phase = rng.uniform(-np.pi, np.pi, 500)
    x = modulus * np.exp(1j * phase)
    tau = 1.0
    y = soft_threshold(x, tau)
    kept = modulus > tau
    # closed form; 1e-14: a few roundings of O(1) numbers
    np.testing.assert_allclose(np.abs(y), np.maximum(modulus - tau, 0.0), atol=1e-14)
    np.testing.assert_allclose(np.angle(y[kept]), phase[kept], atol=1e-12)
    assert np.all(y[~kept] == 0)
    # not the "real and imaginary parts separately" shrinkage, which changes the phase
    separate = soft_threshold(x.real, tau) + 1j * soft_threshold(x.imag, tau)
    assert not np.allclose(separate[kept], y[kept])


def test_soft_threshold_edge_cases_and_real_input():
    x = np.array([0.0, 0.5, -0.5, 2.0, -3.0])
    np.testing.assert_array_equal(soft_threshold(x, 1.0), [0.0, 0.0, 0.0, 1.0, -2.0])
    z = np.array([0.0 + 0.0j, 1.0 - 1.0j])
    np.testing.assert_array_equal(soft_threshold(z, 0.0), z)  # tau = 0 is the identity
    assert soft_threshold(np.zeros(3, np.complex64), 0.5).dtype == np.complex64
    with pytest.raises(ValueError, match="tau"):
        soft_threshold(x, -1.0)


def test_soft_threshold_is_the_prox_of_the_modulus():
    # shrink(x) minimises 0.5 |z - x|^2 + tau |z|; compare with random competitors
    rng = np.random.default_rng(2)
    x = rng.standard_normal(200) + 1j * rng.standard_normal(200)
    tau = 0.7
    y = soft_threshold(x, tau)

    def objective(z):
        return 0.5 * np.abs(z - x) ** 2 + tau * np.abs(z)

    for _ in range(20):
        z = y + 0.05 * (rng.standard_normal(200) + 1j * rng.standard_normal(200))
        assert np.all(objective(y) <= objective(z) + 1e-15)  # 1e-15: rounding of O(1) terms


def test_singular_value_threshold_matches_formula():
    rng = np.random.default_rng(3)
    x = rng.standard_normal((30, 50)) + 1j * rng.standard_normal((30, 50))
    u, s, vh = np.linalg.svd(x, full_matrices=False)
    tau = float(np.median(s))
    expected = (u * np.maximum(s - tau, 0.0)) @ vh
    low, rank = singular_value_threshold(x, tau)
    assert rank == int(np.sum(s > tau))
    np.testing.assert_allclose(low, expected, atol=1e-12 * s[0])  # two SVDs agree to ~eps
    # the tall (adjoint) path gives the same
    low_t, _ = singular_value_threshold(x.conj().T, tau)
    np.testing.assert_allclose(low_t, expected.conj().T, atol=1e-12 * s[0])


# --------------------------------------------------------------------------------------
# rpca
# --------------------------------------------------------------------------------------
@pytest.mark.parametrize("complex_", [True, False], ids=["complex", "real"])
def test_exact_recovery(complex_):
    # Candes et al. regime: 200 x 300, rank 5, 5 % support with entries of modulus 10
    rng = np.random.default_rng(10)
    low, sparse = low_rank_plus_sparse(rng, 200, 300, rank=5, complex_=complex_)
    res = rpca(low + sparse, tol=1e-7)
    assert isinstance(res, RPCAResult)
    assert res.converged
    assert res.rank == 5
    assert res.low_rank.dtype == (np.complex128 if complex_ else np.float64)
    # stopping at a 1e-7 residual leaves errors of that order; 1e-5 leaves a 100x margin
    assert rel(res.low_rank, low) < 1e-5
    assert rel(res.sparse, sparse) < 1e-5
    assert res.windows == ()
    assert res.eta == pytest.approx(default_eta((200, 300)))


def test_stopping_rule_and_residual_history():
    rng = np.random.default_rng(11)
    low, sparse = low_rank_plus_sparse(rng, 120, 160, rank=4)
    m = low + sparse
    tol = 1e-8
    res = rpca(m, tol=tol)
    assert res.converged
    assert res.residuals.shape == (res.n_iter,)
    assert res.residuals[-1] <= tol
    assert np.all(res.residuals[:-1] > tol)  # stops at the first iterate meeting the rule
    # the last residual is the one of the returned pair (1e-6 relative: float rounding
    # of a difference of O(1) matrices at the 1e-8 level)
    actual = np.linalg.norm(m - res.low_rank - res.sparse) / np.linalg.norm(m)
    assert actual == pytest.approx(res.residuals[-1], rel=1e-6)
    # decreasing-ish: IALM is not monotone in theory; allow a factor 2 per step but
    # require 8 orders of magnitude overall
    assert np.all(res.residuals[1:] <= 2.0 * res.residuals[:-1])
    assert res.residuals[-1] < 1e-6 * res.residuals[0]


def test_not_converged_when_max_iter_too_small():
    rng = np.random.default_rng(12)
    low, sparse = low_rank_plus_sparse(rng, 60, 80, rank=3)
    res = rpca(low + sparse, tol=1e-10, max_iter=3)
    assert not res.converged
    assert res.n_iter == 3
    assert res.residuals.shape == (3,)
    assert res.residuals[-1] > 1e-10


@pytest.mark.parametrize("complex_", [True, False], ids=["complex", "real"])
def test_full_and_partial_svd_agree(complex_):
    rng = np.random.default_rng(13)
    low, sparse = low_rank_plus_sparse(rng, 100, 120, rank=4, complex_=complex_)
    m = low + sparse
    full = rpca(m, svd="full", tol=1e-9)
    partial = rpca(m, svd="partial", tol=1e-9)
    auto = rpca(m, svd="auto", tol=1e-9)
    assert full.n_iter == partial.n_iter == auto.n_iter
    assert full.rank == partial.rank == auto.rank
    # the partial SVD thresholds exactly (it grows until a value falls below the
    # threshold), so both paths compute the same iterates up to rounding: 1e-10
    for other in (partial, auto):
        assert rel(other.low_rank, full.low_rank) < 1e-10
        assert rel(other.sparse, full.sparse) < 1e-10


def test_partial_svd_grows_its_prediction():
    # rank 14 > the initial prediction of 10 singular values: the partial path must grow
    rng = np.random.default_rng(14)
    low, sparse = low_rank_plus_sparse(rng, 110, 120, rank=14, density=0.02)
    full = rpca(low + sparse, svd="full", tol=1e-8)
    partial = rpca(low + sparse, svd="partial", tol=1e-8)
    assert partial.rank == full.rank == 14
    assert rel(partial.low_rank, full.low_rank) < 1e-9  # same iterates, rounding only


@pytest.mark.parametrize(
    ("dtype", "expected"),
    [
        (np.complex64, np.complex64),
        (np.complex128, np.complex128),
        (np.float32, np.float32),
        (np.int64, np.float64),
    ],
)
def test_output_dtype_follows_input(dtype, expected):
    rng = np.random.default_rng(15)
    low, sparse = low_rank_plus_sparse(
        rng, 40, 50, rank=2, complex_=np.issubdtype(dtype, np.complexfloating)
    )
    m = np.round(low + sparse) if np.issubdtype(dtype, np.integer) else low + sparse
    res = rpca(m.astype(dtype), tol=1e-6)
    assert res.low_rank.dtype == expected
    assert res.sparse.dtype == expected
    assert res.residuals.dtype == np.float64


def test_zero_matrix():
    res = rpca(np.zeros((5, 7), np.complex128))
    assert res.converged and res.n_iter == 0 and res.rank == 0
    assert not res.low_rank.any() and not res.sparse.any()


def test_only_low_rank_or_only_sparse():
    rng = np.random.default_rng(16)
    low, sparse = low_rank_plus_sparse(rng, 80, 100, rank=3)
    # 1e-5: stopping at 1e-7 plus the exact-recovery margin, as in test_exact_recovery
    assert rel(rpca(low, tol=1e-8).low_rank, low) < 1e-5
    assert rel(rpca(sparse, tol=1e-8).sparse, sparse) < 1e-5


# --------------------------------------------------------------------------------------
# bad input
# --------------------------------------------------------------------------------------
def test_bad_input_raises_informative_errors():
    good = np.ones((4, 5), np.complex128)
    bad = good.copy()
    bad[1, 2] = np.nan
    with pytest.raises(ValueError, match=r"M must be finite, got 1 NaN/inf"):
        rpca(bad)
    with pytest.raises(
        ValueError, match=r"M must be 2-D \(n_pulses, n_samples\), got shape \(5,\)"
    ):
        rpca(np.ones(5))
    with pytest.raises(ValueError, match=r"got shape \(2, 3, 4\)"):
        windowed_rpca(np.ones((2, 3, 4)))
    for eta in (0.0, -1.0, np.inf):
        with pytest.raises(ValueError, match="eta must be (finite|> 0)"):
            rpca(good, eta=eta)
    with pytest.raises(ValueError, match="eta must be > 0, got -0.5"):
        windowed_rpca(good, window=2, eta=-0.5)
    with pytest.raises(ValueError, match="tol must be > 0, got 0"):
        rpca(good, tol=0)
    with pytest.raises(ValueError, match="max_iter must be >= 1, got 0"):
        rpca(good, max_iter=0)
    with pytest.raises(TypeError, match="max_iter must be an int"):
        rpca(good, max_iter=10.5)
    with pytest.raises(ValueError, match="rho must be finite and >= 1, got 0.5"):
        rpca(good, rho=0.5)
    with pytest.raises(ValueError, match="mu must be > 0"):
        rpca(good, mu=-1.0)
    with pytest.raises(ValueError, match="svd must be one of"):
        rpca(good, svd="propack")
    with pytest.raises(ValueError, match="must be non-empty"):
        rpca(np.ones((0, 3)))
    with pytest.raises(TypeError, match="numeric"):
        rpca(np.array([["a", "b"], ["c", "d"]]))
    with pytest.raises(ValueError, match=r"overlap must be in \[0, 1\), got 1.0"):
        windowed_rpca(good, window=2, overlap=1.0)
    with pytest.raises(ValueError, match="window must be >= 1"):
        windowed_rpca(good, window=0)


# --------------------------------------------------------------------------------------
# windows
# --------------------------------------------------------------------------------------
@pytest.mark.parametrize(
    ("n_samples", "window", "overlap"),
    [(100, 20, 0.5), (101, 32, 0.5), (424, 64, 0.25), (50, 16, 0.75), (37, 10, 0.0), (9, 9, 0.5)],
)
def test_window_bounds_and_partition_of_unity(n_samples, window, overlap):
    bounds = window_bounds(n_samples, window, overlap)
    assert bounds[0][0] == 0 and bounds[-1][1] == n_samples
    assert all(b - a == min(window, n_samples) for a, b in bounds)
    hop = max(1, round(window * (1 - overlap)))
    starts = np.array([a for a, _ in bounds])
    assert np.all(np.diff(starts) <= hop)  # at least the requested overlap
    w = window_weights(bounds, n_samples)
    assert w.shape == (len(bounds), n_samples)
    np.testing.assert_allclose(w.sum(axis=0), 1.0, rtol=0, atol=1e-15)  # rounding only
    assert np.all(w >= 0)
    for i, (a, b) in enumerate(bounds):
        assert not w[i, :a].any() and not w[i, b:].any()
        assert np.all(w[i, a:b] > 0)


def test_window_weights_are_squared_sine_pairs_at_half_overlap():
    bounds = window_bounds(96, 32, 0.5)  # starts 0, 16, ..., 64: exactly half overlap
    assert bounds == ((0, 32), (16, 48), (32, 64), (48, 80), (64, 96))
    w = window_weights(bounds, 96)
    ramp = np.sin(0.5 * np.pi * (np.arange(16) + 0.5) / 16) ** 2
    np.testing.assert_allclose(w[1, 16:32], ramp, atol=1e-15)
    np.testing.assert_allclose(w[0, 16:32], 1 - ramp, atol=1e-15)
    np.testing.assert_array_equal(w[0, :16], 1.0)  # flat at the left edge
    np.testing.assert_array_equal(w[-1, 80:], 1.0)  # and at the right edge


def test_window_weights_reject_gaps():
    with pytest.raises(ValueError, match="sample 10 is in none"):
        window_weights(((0, 10), (11, 20)), 20)


def test_windowed_reassembly_is_exact():
    rng = np.random.default_rng(20)
    low, sparse = column_blocks(rng, 48, 6, 30, 2)
    m = low + sparse
    calls = []
    res = windowed_rpca(
        m, window=40, overlap=0.5, tol=1e-8, progress=lambda stage, i, n: calls.append((i, n))
    )
    n_windows = len(res.windows)
    assert n_windows > 3
    assert calls == [(i + 1, n_windows) for i in range(n_windows)]
    assert res.converged and all(res.window_converged)
    assert res.n_iter == max(res.window_n_iter)
    assert res.residuals[-1] <= 1e-8
    # L + S = M over the whole matrix: each window meets 1e-8 and the weights sum to 1;
    # 1e-6 leaves room for the sum over ~n_windows overlapping windows
    assert rel(res.low_rank + res.sparse, m) < 1e-6


def test_one_window_is_plain_rpca():
    rng = np.random.default_rng(21)
    low, sparse = low_rank_plus_sparse(rng, 50, 60, rank=2)
    m = low + sparse
    plain = rpca(m, tol=1e-8)
    for window in (60, 1000):
        win = windowed_rpca(m, window=window, tol=1e-8)
        assert win.windows == ((0, 60),)
        np.testing.assert_array_equal(win.low_rank, plain.low_rank)
        np.testing.assert_array_equal(win.sparse, plain.sparse)
        assert win.n_iter == plain.n_iter and win.rank == plain.rank


def test_windowed_beats_whole_matrix_on_blockwise_low_rank_data():
    # 8 blocks of 32 columns, each rank 3 in its own subspace: rank 24 of 64 globally
    # (too high for principal component pursuit) but at most 6 in any 64-column window
    rng = np.random.default_rng(22)
    low, sparse = column_blocks(rng, 64, 8, 32, 3)
    m = low + sparse
    whole = rpca(m, tol=1e-7)
    whole_eta = rpca(m, tol=1e-7, eta=1 / np.sqrt(64))  # the window's eta on the whole
    windowed = windowed_rpca(m, window=64, tol=1e-7)
    err_whole, err_whole_eta = rel(whole.sparse, sparse), rel(whole_eta.sparse, sparse)
    err_windowed = rel(windowed.sparse, sparse)
    # measured 0.31, 0.029 and 1.3e-7: the margins are orders of magnitude
    assert err_windowed < 1e-5
    assert err_whole > 1e-2 and err_whole_eta > 1e-3
    assert rel(windowed.low_rank, low) < 1e-5


def test_choose_window():
    rng = np.random.default_rng(23)
    low, sparse = low_rank_plus_sparse(rng, 200, 300, rank=5)
    assert choose_window(low + sparse) == 300  # globally low rank: the whole matrix
    low, sparse = column_blocks(np.random.default_rng(22), 64, 8, 32, 3)
    w = choose_window(low + sparse)
    assert w == 64  # rank <= 6 per 64 columns, but 10+ per 128
    assert 16 <= choose_window(low + sparse, max_rank_fraction=1e-3) <= 64  # fallback
    assert choose_window(np.zeros((10, 40))) == 40
    assert choose_window(low + sparse, max_window=32) <= 32
    assert choose_window(np.ones((5, 8)), min_window=16) == 8  # bounded by n_samples


def test_windowed_default_window_uses_choose_window():
    low, sparse = column_blocks(np.random.default_rng(22), 64, 4, 32, 2)
    res = windowed_rpca(low + sparse, tol=1e-6)
    width = choose_window(low + sparse)
    assert all(b - a == width for a, b in res.windows)


# --------------------------------------------------------------------------------------
# accelerated alternating projections
# --------------------------------------------------------------------------------------
@pytest.mark.parametrize("shape", [(200, 300), (117, 424)])
def test_accaltproj_recovers_planted_low_rank_plus_sparse(shape):
    rng = np.random.default_rng(30)
    low, sparse = low_rank_plus_sparse(rng, *shape, rank=5)
    m = low + sparse
    fast = rpca(m, tol=1e-7, solver="accaltproj")
    assert fast.converged and fast.rank == 5  # rank found by the Gavish-Donoho rule
    # Stopping at a 1e-7 residual leaves errors of that order (~2e-7 measured).
    assert rel(fast.low_rank, low) < 1e-5
    assert rel(fast.sparse, sparse) < 1e-5
    # Same decomposition as principal component pursuit (IALM) on these matrices.
    slow = rpca(m, tol=1e-7)
    assert rel(fast.low_rank, slow.low_rank) < 1e-5
    assert rel(fast.sparse, slow.sparse) < 1e-5
    assert fast.n_iter < 30 and fast.residuals[-1] <= 1e-7


def test_accaltproj_options_dtype_and_windows():
    rng = np.random.default_rng(31)
    low, sparse = low_rank_plus_sparse(rng, 120, 160, rank=3)
    m = (low + sparse).astype(np.complex64)
    res = rpca(m, tol=1e-5, solver="accaltproj", rank=3)
    assert res.low_rank.dtype == np.complex64 and res.rank == 3
    assert rel(res.sparse, sparse) < 1e-4
    # A heavier weight on ||S||_1 is a higher threshold: fewer entries in S.
    light = rpca(low + sparse, tol=1e-5, solver="accaltproj", eta=0.5 * default_eta(m.shape))
    heavy = rpca(low + sparse, tol=1e-5, solver="accaltproj", eta=4.0 * default_eta(m.shape))
    assert np.count_nonzero(heavy.sparse) <= np.count_nonzero(light.sparse)
    # Windowed: each window by the same solver, blended as for IALM.
    w = windowed_rpca(low + sparse, window=64, solver="accaltproj", tol=1e-6)
    assert w.converged and len(w.windows) > 1
    np.testing.assert_allclose(w.low_rank + w.sparse, low + sparse, atol=1e-4)
    assert rpca(np.zeros((5, 6)), solver="accaltproj").converged
    with pytest.raises(ValueError, match="solver"):
        rpca(m, solver="svt")
    with pytest.raises(ValueError, match="rank"):
        rpca(m, solver="accaltproj", rank=0)
    with pytest.raises(TypeError, match="rank"):
        windowed_rpca(m, solver="accaltproj", rank=2.5)


def test_single_precision_svds_keep_the_decomposition(monkeypatch):
    """At ``tol >= 1e-5`` full SVDs run in complex64: same iterations, ``S`` within 1e-5.

    A 200 x 160 complex rank-40 + 5 %-sparse matrix (rank above the partial-SVD limit,
    so every SVD is full); the double-precision run is forced by raising the tolerance
    at which single precision starts. Measured: 20 iterations each, ``S`` within 2.4e-7.
    """
    import importlib

    mod = importlib.import_module("sarmotion.separation._thresholding")
    ialm = importlib.import_module("sarmotion.separation._ialm")
    rng = np.random.default_rng(11)
    u = rng.standard_normal((200, 40)) + 1j * rng.standard_normal((200, 40))
    v = rng.standard_normal((40, 160)) + 1j * rng.standard_normal((40, 160))
    m = u @ v / np.sqrt(80)
    mask = rng.random(m.shape) < 0.05
    m[mask] += 10 * np.exp(2j * np.pi * rng.random(mask.sum()))
    calls = []
    svd = mod.scipy.linalg.svd

    def spy(a, *args, **kwargs):
        calls.append(a.dtype)
        return svd(a, *args, **kwargs)

    monkeypatch.setattr(mod.scipy.linalg, "svd", spy)
    single = rpca(m, tol=1e-5, svd="full")
    assert np.complex64 in calls  # the fast path ran
    calls.clear()
    monkeypatch.setattr(ialm, "_SINGLE_PRECISION_TOL", np.inf)
    double = rpca(m, tol=1e-5, svd="full")
    assert np.complex64 not in calls
    assert single.converged and double.converged
    assert single.n_iter == double.n_iter
    rel = np.linalg.norm(single.sparse - double.sparse) / np.linalg.norm(double.sparse)
    assert rel <= 1e-5, rel
