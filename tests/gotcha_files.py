"""Small GOTCHA-format files for the reader and command-line tests."""

from __future__ import annotations

import numpy as np
import scipy.io


def small_struct(n_pulses=5, n_freq=16, *, az0_deg=0.0, seed=0):
    """A valid, tiny GOTCHA-like ``data`` struct (dict for scipy.io.savemat)."""
    rng = np.random.default_rng(seed)
    az = np.deg2rad(az0_deg + np.arange(n_pulses) * 0.00853)
    x, y, z = 7089.0 * np.cos(az), 7089.0 * np.sin(az), np.full(n_pulses, 7275.0)
    f = 9.28808e9 + 1.471488e6 * np.arange(n_freq)
    fp = rng.standard_normal((n_freq, n_pulses)) + 1j * rng.standard_normal((n_freq, n_pulses))

    def row(v):
        return np.asarray(v, np.float32)[None, :]

    return {
        "fp": fp.astype(np.complex64),
        "freq": f.astype(np.float32)[:, None],
        "x": row(x),
        "y": row(y),
        "z": row(z),
        "r0": row(np.sqrt(x**2 + y**2 + z**2)),
        "th": row(np.rad2deg(az)),
        "phi": row(np.rad2deg(np.arctan2(z, np.hypot(x, y)))),
        "af": {"r_correct": row(np.zeros(n_pulses)), "ph_correct": row(np.zeros(n_pulses))},
    }


def save_struct(path, struct):
    """Write ``struct`` as the ``data`` variable of a MATLAB file at ``path``."""
    scipy.io.savemat(path, {"data": struct})
    return path
