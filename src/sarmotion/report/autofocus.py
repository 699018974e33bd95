"""The autofocus figure: the estimated phase error per pulse and the convergence."""

from __future__ import annotations

import numpy as np
from matplotlib.figure import Figure
from numpy.typing import ArrayLike

from .plotting import subplots

__all__ = ["phase_error_figure"]


def phase_error_figure(
    slow_times_s: ArrayLike,
    phase_error_rad: ArrayLike,
    rms_history_rad: ArrayLike,
    *,
    tol_rad: float | None = None,
    title: str = "phase-gradient autofocus",
) -> Figure:
    """Estimated phase error ``phi(s)`` (rad) and the RMS correction per iteration.

    Parameters
    ----------
    slow_times_s : (n_pulses,) array_like
        Slow times (s).
    phase_error_rad : (n_pulses,) array_like
        Estimated phase error (rad), mean and linear term removed.
    rms_history_rad : (n_iter,) array_like
        RMS of each iteration's correction (rad).
    tol_rad : float, optional
        The stopping tolerance, drawn as a line.
    title : str
        Figure title.
    """
    s = np.asarray(slow_times_s, dtype=np.float64)
    phi = np.asarray(phase_error_rad, dtype=np.float64)
    rms = np.asarray(rms_history_rad, dtype=np.float64)
    fig, (a, b) = subplots(1, 2, figsize=(9.0, 3.4))
    fig.set_layout_engine("constrained")
    a.plot(s, phi, color="C0")
    a.set_xlabel("slow time s (s)")
    a.set_ylabel("phase error (rad)")
    a.set_title(f"estimated phase error, RMS {np.sqrt(np.mean(phi**2)):.3g} rad")
    a.grid(alpha=0.3)
    it = np.arange(1, rms.size + 1)
    b.semilogy(it, np.maximum(rms, 1e-12), "o-", color="C1")
    if tol_rad is not None:
        b.axhline(tol_rad, color="0.5", ls="--", label="tolerance")
        b.legend(loc="upper right")
    b.set_xlabel("iteration")
    b.set_ylabel("RMS correction (rad)")
    b.set_title("convergence")
    b.grid(alpha=0.3)
    fig.suptitle(title)
    return fig
