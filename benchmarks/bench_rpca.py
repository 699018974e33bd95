"""Benchmarks of sarmotion.separation.rpca against a textbook full-SVD IALM.

Run with::

    pytest benchmarks/bench_rpca.py --benchmark-enable -p no:cacheprovider

Sizes: 117 x 424 ("scene1-sized", one degree of GOTCHA pulses by the scene's fast-time
samples) and 468 x 424 (four degrees). The matrices are complex: a rank-5 part with
O(1) entries plus 5 % spikes of modulus 10 (random phases). ``extra_info`` holds the
iterations, the best wall time in seconds and the recovery errors.

``test_accaltproj`` times the accelerated alternating projections solver with the
textbook IALM in the same run (``speed_up``, errors of both, their agreement);
``test_gotcha_windows`` runs windowed RPCA (stacked IALM, or AccAltProj) on each GOTCHA
degree with two injected movers and, in the same run, the plain full-SVD IALM per
window: median times (the plain one with one BLAS thread and with the default threads),
median speed-ups, and for both the clutter left in ``S`` and the movers' coverage.
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


def reference_ialm(
    m: np.ndarray, *, eta: float | None = None, tol: float = TOL, max_iter: int = 1000
):
    """Textbook inexact ALM (Lin, Chen & Ma 2010, Alg. 5), full SVD every iteration.

    ``eta`` defaults to ``1 / sqrt(max(m.shape))``. Returns ``(L, S, iterations,
    converged)``.
    """
    eta = 1.0 / np.sqrt(max(m.shape)) if eta is None else eta
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


# --------------------------------------------------------------------------------------
# Accelerated alternating projections against the plain full-SVD IALM, same run
# --------------------------------------------------------------------------------------
def _rel(a, b):
    return float(np.linalg.norm(a - b) / np.linalg.norm(b))


@pytest.mark.parametrize("size", list(SIZES))
def test_accaltproj(benchmark, size):
    """``extra_info``: ``speed_up`` over :func:`reference_ialm` (one BLAS thread for both,
    best of 3 each), the recovery errors of both and their agreement."""
    from threadpoolctl import threadpool_limits

    low, sparse = make_matrix(*SIZES[size])
    m = low + sparse
    with threadpool_limits(limits=1, user_api="blas"):
        ref_times = []
        for _ in range(3):
            t0 = time.perf_counter()
            low_ref, sparse_ref, it_ref, _ = reference_ialm(m, tol=TOL)
            ref_times.append(time.perf_counter() - t0)
        res = _run(benchmark, lambda: rpca(m, tol=TOL, solver="accaltproj"))
    benchmark.extra_info.update(
        {
            "n_iter": res.n_iter,
            "rank": res.rank,
            "converged": res.converged,
            "reference_ialm_seconds": min(ref_times),
            "reference_ialm_n_iter": it_ref,
            "speed_up": min(ref_times) / benchmark.extra_info["seconds"],
            "rel_err_low_rank_reference": _rel(low_ref, low),
            "rel_err_sparse_reference": _rel(sparse_ref, sparse),
            "rel_diff_low_rank_vs_reference": _rel(res.low_rank, low_ref),
            "rel_diff_sparse_vs_reference": _rel(res.sparse, sparse_ref),
        }
    )
    _errors(benchmark, res.low_rank, res.sparse, low, sparse)
    assert res.converged


def _gotcha_files():
    import os
    from pathlib import Path

    env = os.environ.get("SARMOTION_GOTCHA_DIR")
    root = Path(__file__).resolve().parents[1]
    for d in ([Path(env)] if env else []) + [root.parent / "shared" / "data" / "gotcha"]:
        if d.is_dir():
            files = sorted(d.glob("data_3dsar_pass1_az00*_HH.mat"))
            if files:
                return files
    pytest.skip("GOTCHA data not found")


def _gotcha_degree(index: int = 0):
    return _gotcha_files()[index]


def _with_movers(paths):
    """GOTCHA clutter and the two injected movers of the separation test."""
    from sarmotion.io import read_gotcha
    from sarmotion.simulation import PointTarget, inject

    clutter = read_gotcha(paths)
    amp = float(np.median(np.abs(clutter.data).max(axis=1)))
    movers = [
        PointTarget(position_m=[5.0, -10.0], velocity_mps=[8.0, 3.0], reflectivity=amp),
        PointTarget(position_m=[-12.0, 6.0], velocity_mps=[-6.0, 4.0], reflectivity=amp),
    ]
    return clutter, inject(clutter, movers), movers


def _clutter_left_db(sparse, m, clutter):
    d = sparse - (m - clutter)
    return float(10 * np.log10(np.vdot(d, d).real / np.vdot(clutter, clutter).real))


def _same_run(fn_new, fn_ref, *, repeats: int = 5) -> dict:
    """Same-run ratios on a shared machine: ``fn_new`` and ``fn_ref`` run alternately
    ``repeats`` times with ``fn_ref`` on one BLAS thread, then alternately again with
    ``fn_ref`` on the default threads (OpenBLAS workers left spinning by a threaded call
    would slow the single-threaded runs next to it, hence two separate series). Median
    times and the medians of the per-pair ratios, with the 1-min load average."""
    import os

    from threadpoolctl import threadpool_limits

    def series(limit):
        t_new, t_ref = [], []
        for _ in range(repeats):
            t0 = time.perf_counter()
            fn_new()
            t_new.append(time.perf_counter() - t0)
            with threadpool_limits(limits=limit, user_api="blas"):
                t0 = time.perf_counter()
                fn_ref()
                t_ref.append(time.perf_counter() - t0)
        return np.array(t_new), np.array(t_ref)

    load = [os.getloadavg()[0]]
    new1, ref1 = series(1)
    load.append(os.getloadavg()[0])
    newd, refd = series(None)
    load.append(os.getloadavg()[0])
    return {
        "seconds_median": float(np.median(new1)),
        "reference_ialm_seconds": float(np.median(ref1)),
        "speed_up_vs_reference_ialm": float(np.median(ref1 / new1)),
        "seconds_median_beside_default_threads": float(np.median(newd)),
        "reference_ialm_default_threads_seconds": float(np.median(refd)),
        "speed_up_vs_reference_ialm_default_threads": float(np.median(refd / newd)),
        "load_average_1min": load,
    }


@pytest.mark.parametrize("degree", [0, 1, 2, 3])
@pytest.mark.parametrize("solver", ["ialm", "accaltproj"])
def test_gotcha_windows(benchmark, solver, degree):
    """Windowed RPCA of one GOTCHA degree with two injected movers (the separation test's
    case: windows of 64, ``eta`` x 2, ``tol = 1e-5``) against the plain full-SVD IALM
    (:func:`reference_ialm` per window) in the same run: median seconds of both
    (the plain one with one BLAS thread and with the default threads), their median
    ratio, and for both the clutter left in ``S`` (dB of the clutter energy) and the
    movers' trace coverage. ``solver="ialm"`` is the stacked IALM of
    :func:`windowed_rpca` (same iterates as the plain one)."""
    from sarmotion.separation import (
        default_eta,
        mover_trace_coverage,
        window_bounds,
        window_weights,
    )

    clutter, data, movers = _with_movers([_gotcha_degree(degree)])
    m = data.data
    mc = m.astype(np.complex128)
    eta = 2.0 * default_eta((m.shape[0], 64))
    bounds = window_bounds(m.shape[1], 64, 0.5)
    weights = window_weights(bounds, m.shape[1])

    def new():
        return windowed_rpca(m, window=64, eta=eta, tol=1e-5, solver=solver)

    def plain():
        s = np.zeros_like(mc)
        for i, (a, b) in enumerate(bounds):
            s[:, a:b] += weights[i, a:b] * reference_ialm(mc[:, a:b], eta=eta, tol=1e-5)[1]
        return s

    res = _run(benchmark, new)
    s_ref = plain()
    benchmark.extra_info.update(_same_run(new, plain))
    benchmark.extra_info.update(
        {
            "solver": solver,
            "degree": degree,
            "windows": len(bounds),
            "window_n_iter": list(res.window_n_iter),
            "window_ranks": list(res.window_ranks),
            "clutter_left_db": _clutter_left_db(res.sparse, m, clutter.data),
            "reference_clutter_left_db": _clutter_left_db(s_ref, m, clutter.data),
            "mover_coverage": [mover_trace_coverage(res.sparse, data, [mv]) for mv in movers],
            "reference_mover_coverage": [mover_trace_coverage(s_ref, data, [mv]) for mv in movers],
            "rel_diff_sparse_vs_reference": _rel(res.sparse, s_ref),
        }
    )


def apg_pcp(blocks: np.ndarray, *, eta: float, tol: float = 3e-3, max_iter: int = 300):
    """Accelerated proximal gradient on ``S`` for ``min ||M - S||_* + eta ||S||_1``.

    A measured alternative, not used by the library: where ``L = M - S`` has full column
    rank the nuclear norm is differentiable with gradient ``U V^H`` (the polar factor,
    here from the Gram matrix's eigen-decomposition), so FISTA applies::

        S+ = shrink(Z + t P(M - Z), t eta),   t = 1.9 sigma_min(M - Z),

    with momentum reset when ``<Z - S+, S+ - S> > 0`` (gradient restart) and a stop when
    ``||S+ - Z||_F <= tol ||M||_F``. ``t`` stays below ``2 / Lipschitz``: the gradient's
    Lipschitz constant near a full-rank ``L`` is ``1 / sigma_min(L)``. Returns ``S`` of
    each matrix of the stack ``blocks`` and the iterations (one thresholding each).
    """
    fro = np.linalg.norm(blocks, axis=(1, 2))
    s = np.zeros_like(blocks)
    z = s.copy()
    tk = np.ones(len(blocks))
    out = np.zeros_like(blocks)
    its = np.zeros(len(blocks), dtype=int)
    act = np.arange(len(blocks))
    for k in range(1, max_iter + 1):
        a = blocks[act] - z
        w, v = np.linalg.eigh(a.conj().swapaxes(1, 2) @ a)
        sig = np.sqrt(np.maximum(w, 1e-300))
        p = a @ ((v / sig[:, None, :]) @ v.conj().swapaxes(1, 2))
        t = 1.9 * sig[:, :1, None]
        x = z + t * p
        mag = np.abs(x)
        s_new = x * np.maximum(1 - t * eta / np.maximum(mag, 1e-300), 0)
        tk[np.einsum("kij,kij->k", (z - s_new).conj(), s_new - s).real > 0] = 1.0
        tn = (1 + np.sqrt(1 + 4 * tk * tk)) / 2
        z_new = s_new + ((tk - 1) / tn)[:, None, None] * (s_new - s)
        done = (np.linalg.norm(s_new - z, axis=(1, 2)) <= tol * fro[act]) | (k == max_iter)
        out[act[done]] = s_new[done]
        its[act[done]] = k
        keep = ~done
        act = act[keep]
        if not act.size:
            break
        s, tk, z = s_new[keep], tn[keep], z_new[keep]
    return out, its


@pytest.mark.parametrize("degree", [0, 1, 2, 3])
def test_gotcha_minimiser(benchmark, degree):
    """How far the plain IALM at ``tol = 1e-5`` is from principal component pursuit's
    minimiser on the GOTCHA windows of :func:`test_gotcha_windows`, and what a solver
    converging to the minimiser gains. The minimiser: the stacked IALM with ``rho = 1.02``
    to ``tol = 1e-10`` (``rho = 1.05``, ``tol = 1e-9`` agrees to 1e-7 in the objective);
    its ``L`` has full rank in every window (``sigma_min / sigma_max`` reported). Timed:
    :func:`apg_pcp`, against the plain IALM in the same run; clutter left and coverage of
    the plain IALM, the minimiser and :func:`apg_pcp`."""
    from threadpoolctl import threadpool_limits

    from sarmotion.separation import (
        default_eta,
        mover_trace_coverage,
        window_bounds,
        window_weights,
    )
    from sarmotion.separation._stacked_ialm import stacked_ialm

    clutter, data, movers = _with_movers([_gotcha_degree(degree)])
    m = data.data.astype(np.complex128)
    eta = 2.0 * default_eta((m.shape[0], 64))
    bounds = window_bounds(m.shape[1], 64, 0.5)
    weights = window_weights(bounds, m.shape[1])
    blocks = np.stack([m[:, a:b] for a, b in bounds])

    def blend(pieces):
        out = np.zeros_like(m)
        for i, (a, b) in enumerate(bounds):
            out[:, a:b] += weights[i, a:b] * pieces[i]
        return out

    def plain():
        return [reference_ialm(x, eta=eta, tol=1e-5)[:3] for x in blocks]

    def apg():
        with threadpool_limits(limits=1, user_api="blas"):  # as the library's solvers
            return apg_pcp(blocks, eta=eta)

    s_apg, its = _run(benchmark, apg)
    refs = plain()
    _, s_min, _, conv, _, _ = stacked_ialm(blocks, eta=eta, tol=1e-10, max_iter=5000, rho=1.02)
    sv = np.linalg.svd(blocks - s_min, compute_uv=False)
    found = {
        "plain_ialm": blend([r[1] for r in refs]),
        "minimiser": blend(s_min),
        "apg": blend(s_apg),
    }
    benchmark.extra_info.update(_same_run(apg, plain))
    benchmark.extra_info.update(
        {
            "degree": degree,
            "minimiser_converged": all(conv),
            "minimiser_sigma_min_over_max": [float(v) for v in sv[:, -1] / sv[:, 0]],
            "plain_ialm_iterations": int(sum(r[2] for r in refs)),
            "apg_iterations": int(its.sum()),
            **{
                f"clutter_left_db_{k}": _clutter_left_db(v, m, clutter.data)
                for k, v in found.items()
            },
            **{
                f"mover_coverage_{k}": [mover_trace_coverage(v, data, [mv]) for mv in movers]
                for k, v in found.items()
            },
        }
    )


def test_gotcha_four_degrees_as_analyze(benchmark):
    """The analysis's case: the 4 GOTCHA degrees with two injected movers as one window
    (``choose_window`` picks the whole 424 samples), ``eta`` x 2, ``tol = 1e-4``; seconds,
    iterations, rank of ``L`` and clutter left against :func:`reference_ialm` (double
    precision, full SVDs) in the same run, as in :func:`test_gotcha_windows`."""
    from sarmotion.separation import default_eta

    clutter, data, _ = _with_movers(_gotcha_files())
    m = data.data
    mc = m.astype(np.complex128)
    eta = 2.0 * default_eta(m.shape)

    def new():
        return rpca(m, eta=eta, tol=1e-4)

    def plain():
        return reference_ialm(mc, eta=eta, tol=1e-4)[:3]

    res = _run(benchmark, new)
    _, sparse_ref, it_ref = plain()
    benchmark.extra_info.update(_same_run(new, plain, repeats=3))
    benchmark.extra_info.update(
        {
            "n_iter": res.n_iter,
            "rank": res.rank,
            "clutter_left_db": _clutter_left_db(res.sparse, m, clutter.data),
            "reference_ialm_n_iter": it_ref,
            "reference_clutter_left_db": _clutter_left_db(sparse_ref, m, clutter.data),
        }
    )
