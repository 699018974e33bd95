"""Benchmarks of sarmotion.separation.rpca against a textbook full-SVD IALM.

Run with::

    pytest benchmarks/bench_rpca.py --benchmark-enable -p no:cacheprovider

Sizes: 117 x 424 ("scene1-sized", one degree of GOTCHA pulses by the scene's fast-time
samples) and 468 x 424 (four degrees). The matrices are complex: a rank-5 part with
O(1) entries plus 5 % spikes of modulus 10 (random phases). ``extra_info`` holds the
iterations, the best wall time in seconds and the recovery errors.
"""

from __future__ import annotations

import time

import numpy as np
import pytest

from sarmotion.separation import rpca, windowed_rpca

TOL = 1e-7
SIZES = {"scene1_117x424": (117, 424), "4deg_468x424": (468, 424)}


def make_matrix(n: int, m: int, *, rank: int = 5, density: float = 0.05, seed: int = 0):
    rng = np.random.default_rng(seed)
    u = rng.standard_normal((n, rank)) + 1j * rng.standard_normal((n, rank))
    v = rng.standard_normal((rank, m)) + 1j * rng.standard_normal((rank, m))
    low = u @ v / np.sqrt(2 * rank)
    support = rng.random((n, m)) < density
    sparse = np.zeros_like(low)
    sparse[support] = 10.0 * np.exp(2j * np.pi * rng.random(support.sum()))
    return low, sparse


def reference_ialm(m: np.ndarray, *, tol: float = TOL, max_iter: int = 1000):
    """Textbook inexact ALM (Lin, Chen & Ma 2010, Alg. 5), full SVD every iteration."""
    eta = 1.0 / np.sqrt(max(m.shape))
    norm_two = np.linalg.norm(m, 2)
    y = m / max(norm_two, np.abs(m).max() / eta)
    mu = 1.25 / norm_two
    mu_bar = mu * 1e7
    rho = 1.5
    norm_fro = np.linalg.norm(m)
    low = np.zeros_like(m)
    sparse = np.zeros_like(m)
    for k in range(1, max_iter + 1):
        t = m - low + y / mu
        mag = np.abs(t)
        sparse = t * np.maximum(mag - eta / mu, 0) / np.where(mag > 0, mag, 1)
        u, s, vh = np.linalg.svd(m - sparse + y / mu, full_matrices=False)
        r = int(np.sum(s > 1 / mu))
        low = (u[:, :r] * (s[:r] - 1 / mu)) @ vh[:r]
        z = m - low - sparse
        y = y + mu * z
        mu = min(mu * rho, mu_bar)
        if np.linalg.norm(z) / norm_fro <= tol:
            return low, sparse, k, True
    return low, sparse, max_iter, False


def _run(benchmark, fn):
    times: list[float] = []
    out = {}

    def timed():
        t0 = time.perf_counter()
        out["result"] = fn()
        times.append(time.perf_counter() - t0)
        return out["result"]

    benchmark.pedantic(timed, rounds=3, iterations=1, warmup_rounds=0)
    benchmark.extra_info["seconds"] = min(times)
    return out["result"]


def _errors(benchmark, low_hat, sparse_hat, low, sparse):
    benchmark.extra_info["rel_err_low_rank"] = float(
        np.linalg.norm(low_hat - low) / np.linalg.norm(low)
    )
    benchmark.extra_info["rel_err_sparse"] = float(
        np.linalg.norm(sparse_hat - sparse) / np.linalg.norm(sparse)
    )


@pytest.mark.parametrize("size", list(SIZES))
def test_rpca_auto(benchmark, size):
    low, sparse = make_matrix(*SIZES[size])
    res = _run(benchmark, lambda: rpca(low + sparse, tol=TOL))
    benchmark.extra_info["n_iter"] = res.n_iter
    benchmark.extra_info["converged"] = res.converged
    _errors(benchmark, res.low_rank, res.sparse, low, sparse)
    assert res.converged


@pytest.mark.parametrize("size", list(SIZES))
def test_rpca_full_svd(benchmark, size):
    low, sparse = make_matrix(*SIZES[size])
    res = _run(benchmark, lambda: rpca(low + sparse, tol=TOL, svd="full"))
    benchmark.extra_info["n_iter"] = res.n_iter
    benchmark.extra_info["converged"] = res.converged
    _errors(benchmark, res.low_rank, res.sparse, low, sparse)
    assert res.converged


@pytest.mark.parametrize("size", list(SIZES))
def test_reference_ialm(benchmark, size):
    low, sparse = make_matrix(*SIZES[size])
    low_hat, sparse_hat, n_iter, converged = _run(
        benchmark, lambda: reference_ialm(low + sparse, tol=TOL)
    )
    benchmark.extra_info["n_iter"] = n_iter
    benchmark.extra_info["converged"] = converged
    _errors(benchmark, low_hat, sparse_hat, low, sparse)
    assert converged


@pytest.mark.parametrize("window", [64, 128])
@pytest.mark.parametrize("size", list(SIZES))
def test_windowed_rpca(benchmark, size, window):
    low, sparse = make_matrix(*SIZES[size])
    res = _run(benchmark, lambda: windowed_rpca(low + sparse, window=window, tol=TOL))
    benchmark.extra_info["n_iter"] = res.n_iter
    benchmark.extra_info["n_windows"] = len(res.windows)
    benchmark.extra_info["total_window_iterations"] = int(sum(res.window_n_iter))
    benchmark.extra_info["converged"] = res.converged
    _errors(benchmark, res.low_rank, res.sparse, low, sparse)
    assert res.converged
