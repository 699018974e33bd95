"""Fast factorised backprojection on an NVIDIA GPU: :func:`ffbp_cuda`.

The plan is the CPU's (:mod:`.ffbp`: the tree of sub-apertures, each depth's filters from
the error budget, the image rows' layout, the pixels near the ends of the fast-time window
computed exactly, the rotated path for oblique looks), made once per geometry and grid
and kept in :data:`.ffbp.PLANS`; :class:`CudaKernels` evaluates it on the GPU
(:mod:`._cuda_ffbp_kernels`), one launch per depth for the leaves and one for the merges.
The leaves read the GPU's trace table (:func:`.cuda.hermite_table`, ``upsample`` points
per sample, cubic Hermite) with float64 ranges, so they are at least as accurate as the
CPU's leaves (the exact kernel's float32 tiles); the merges and the resampling use the
same filters in float32. The error budget of :mod:`.ffbp` therefore holds as on the CPU
(:data:`.ffbp.TARGET_DB` against the exact sum). The pixels near the window ends are the
GPU's exact backprojection (:mod:`.cuda`).

All quantities are SI: metres, seconds, hertz.
"""

from __future__ import annotations

import threading
import weakref
from collections import OrderedDict
from typing import Any

import numpy as np
from numpy.typing import NDArray

from ..core import ProgressCallback, Traces
from ._bp_common import kernel_constants, make_setup, table_samples
from ._bp_kernels import TILES, tile_shape
from ._cuda_host import pool_for
from .ffbp import PLAN_CACHE_ENTRIES, CpuKernels, FfbpPulses, ffbp_values

__all__ = ["CudaKernels", "ffbp_cuda"]

#: Frames (geometry of a plan) whose device arrays are kept: one per plan kept.
_FRAMES_KEPT = PLAN_CACHE_ENTRIES


class CudaKernels(CpuKernels):
    """Evaluates an :mod:`.ffbp` plan on the GPU (:mod:`._cuda_ffbp_kernels`).

    The methods of :class:`.ffbp.CpuKernels`: ``run_levels`` returns device planes,
    ``image_rows`` and ``resample`` write host arrays. The plan's arrays are copied to the
    device once per plan and kept while the plan is (weak references); the sub-image
    planes are device arrays of the call.
    """

    def __init__(self, cuda: Any) -> None:
        self.cuda = cuda
        self._lock = threading.Lock()
        self._levels: weakref.WeakKeyDictionary = weakref.WeakKeyDictionary()
        self._frames: OrderedDict[int, tuple[dict, dict]] = OrderedDict()

    # ----------------------------------------------------------- device copies
    def _frame(self, frame: dict) -> dict:
        """The frame's float64 arrays on the device (kept for :data:`_FRAMES_KEPT` frames)."""
        with self._lock:
            kept = self._frames.get(id(frame))
            if kept is not None and kept[0] is frame:
                self._frames.move_to_end(id(frame))
                return kept[1]
        to = self.cuda.to_device
        dev = {
            "antennas": tuple(to(np.ascontiguousarray(a)) for a in frame["antennas"]),
            "us": to(np.ascontiguousarray(frame["us"])),
            "y": to(np.ascontiguousarray(frame["y"])),
        }
        with self._lock:
            self._frames[id(frame)] = (frame, dev)
            while len(self._frames) > _FRAMES_KEPT:
                self._frames.popitem(last=False)
        return dev

    def _level(self, lv) -> dict:
        """A region's arrays on the device."""
        with self._lock:
            dev = self._levels.get(lv)
        if dev is None:
            to = self.cuda.to_device
            names = ("starts", "stops", "v0", "dv", "nv", "kids", "k0", "g")
            dev = {name: to(np.ascontiguousarray(getattr(lv, name))) for name in names}
            with self._lock:
                self._levels[lv] = dev
        return dev

    # ---------------------------------------------------------------- kernels
    def run_levels(self, levels, frame: dict, table, report):
        """Every region of the tree in order; returns depth 1's planes (device float32)."""
        from . import _cuda_ffbp_kernels as kern

        cuda = self.cuda
        idx_scale, idx_offset, quarter_scale = frame["constants"]
        n_table = int(frame["n_up"])
        cycles_per_m = quarter_scale / 4.0
        cu, cv, cz2, rref = frame["centre"]
        dev = self._frame(frame)
        ax, ay, az2, ref = dev["antennas"]
        nu = frame["us"].size
        planes: dict[int, tuple[Any, Any]] = {}
        cre = cim = cuda.device_array((1, 1, 1), np.float32)
        for lv in levels:
            have = planes.get(lv.slot)
            if have is None or have[0].shape != lv.shape:
                have = planes[lv.slot] = (cuda.device_array(lv.shape, np.float32),
                                          cuda.device_array(lv.shape, np.float32))  # fmt: skip
            re, im = have
            d = self._level(lv)
            n_leaves = lv.starts.size
            if n_leaves:
                rows = int(lv.nv[:n_leaves].max())
                kern.leaves[kern.blocks(nu, rows, n_leaves), kern.BLOCK](
                    re, im, table, n_table, ax, ay, az2, ref, d["starts"], d["stops"],
                    dev["us"], d["v0"], d["dv"], d["nv"], idx_scale,
                    idx_offset - 1.0,  # CPU entry p is sample p - 1; GPU position m is m
                    cycles_per_m, cu, cv, cz2, rref,
                )  # fmt: skip
            n_parents = lv.kids.shape[0]
            if n_parents:
                rows = int(lv.nv[lv.p0 : lv.p0 + n_parents].max())
                kern.merges[kern.blocks(nu, rows, n_parents), kern.BLOCK](
                    re, im, cre, cim, lv.p0, d["kids"], d["k0"], d["g"], d["nv"]
                )  # fmt: skip
            cre, cim = re, im
            report()
        return cre, cim

    def host_image(self, shape: tuple[int, int], covered: bool) -> NDArray[np.complex128]:
        """A pooled page-locked array (:mod:`._cuda_host`), zeroed unless ``covered``."""
        out = pool_for(self.cuda).empty(shape, np.complex128)
        if not covered:
            out[...] = 0.0
        return out

    def image_rows(self, out, k_lo, rows, cre, cim, g, frame: dict, remodulate: bool = True):
        """The image rows (:func:`.ffbp._root_rows`) into ``out[:, k_lo:]`` (host)."""
        from . import _cuda_ffbp_kernels as kern

        cuda = self.cuda
        dev = self._frame(frame)
        ny, nu = frame["y"].size, frame["us"].size
        cu, cv, cz2, rref = frame["centre"]
        key = ("rows", id(rows), id(g))
        kept = dev.get(key)
        if kept is None or kept[0] is not rows or kept[1] is not g:
            kept = dev[key] = (rows, g, [cuda.to_device(np.ascontiguousarray(a))
                                         for a in (*rows, g)])  # fmt: skip
        *row_args, g_dev = kept[2]
        res = cuda.device_array((ny, nu, 2), np.float64)
        kern.root_rows[kern.blocks(nu, ny), kern.BLOCK](
            res, *row_args, cre, cim, g_dev, dev["us"], dev["y"], cu, cv, cz2, rref,
            frame["constants"][2] / 4.0, bool(remodulate),
        )  # fmt: skip
        if out.dtype == np.complex128 and k_lo == 0 and nu == out.shape[1]:
            res.copy_to_host(out.view(np.float64).reshape(ny, nu, 2))  # no host temporary
        else:
            out[:, k_lo : k_lo + nu] = res.copy_to_host().view(np.complex128)[..., 0]

    def resample(self, out, j, *args) -> None:
        """The rotated path's resampling (:func:`._cuda_ffbp_kernels.resample`) into ``out``.

        ``args`` those of :func:`._ffbp_kernels.resample` after ``out`` and ``j``.
        """
        from . import _cuda_ffbp_kernels as kern

        (u0, du, v0, dv, xs, ys, ox, oy, cos_t, sin_t, wu, wv, cx, cy, cz2, rref,
         quarter_scale) = args  # fmt: skip

        cuda = self.cuda
        to = cuda.to_device
        src = to(np.ascontiguousarray(j, np.complex64).view(np.float32).reshape(*j.shape, 2))
        res = cuda.device_array((ys.size, xs.size, 2), np.float64)
        kern.resample[kern.blocks(xs.size, ys.size), kern.BLOCK](
            res, src, u0, du, v0, dv, to(np.ascontiguousarray(xs)), to(np.ascontiguousarray(ys)),
            ox, oy, cos_t, sin_t, to(np.ascontiguousarray(wu)), to(np.ascontiguousarray(wv)),
            cx, cy, cz2, rref, quarter_scale / 4.0,
        )  # fmt: skip
        out[...] = res.copy_to_host().view(np.complex128)[..., 0]


_KERNELS: dict[int, CudaKernels] = {}


def _kernels_for(cuda: Any) -> CudaKernels:
    key = id(cuda)
    kernels = _KERNELS.get(key)
    if kernels is None:
        kernels = _KERNELS[key] = CudaKernels(cuda)
    return kernels


def ffbp_cuda(
    cuda: Any,
    traces: Traces,
    x_m: NDArray[np.float64],
    y_m: NDArray[np.float64],
    velocity_mps: NDArray[np.float64],
    upsample: int,
    *,
    alpha: float | None = None,
    progress: ProgressCallback | None = None,
) -> tuple[NDArray[np.complex128] | None, dict]:
    """FFBP image on the grid ``x_m`` x ``y_m`` on the GPU; returns ``(values, info)``.

    :func:`.ffbp.ffbp_values` with the GPU's table (``upsample`` points per sample) and
    kernels; ``values`` is ``None`` where the factorisation would not save work (the caller
    runs exact backprojection). ``velocity_mps`` ``(3,)`` the compensated ground velocity.
    """
    from . import cuda as gpu

    st = make_setup(traces, velocity_mps, upsample)
    table = gpu.device_table(cuda, traces, upsample)
    n_up = table_samples(traces.n_samples, upsample)
    constants = kernel_constants(st.sample_interval_s, st.carrier_hz, traces.n_samples, n_up)
    quarter_scale = constants.quarter_scale
    cycles_per_m = quarter_scale / 4.0  # 2 nu_o / c
    idx_scale = constants.idx_scale
    ant: list = []  # the antennas on the device, copied when a window end needs them

    def tile_for(pos: NDArray, u: NDArray, v: NDArray) -> tuple[int, int]:
        return tile_shape(pos, u, v, quarter_scale) or TILES[-1]

    def exact_for(x: NDArray, y: NDArray) -> NDArray[np.complex128]:
        dy = abs(float(y[-1]) - float(y[0])) / max(y.size - 1, 1)
        p = gpu.rows_per_thread(st.carrier_hz, dy, x.size * y.size, gpu._min_threads(cuda))
        if not ant:
            ant.append(cuda.to_device(gpu._antennas(st)))
        kernel, args = gpu._launch_exact(cuda, table, n_up, ant[0], x, y, idx_scale,
                                         cycles_per_m, p)  # fmt: skip
        kernel(table, *args)
        return args[-1].copy_to_host().view(np.complex128)[..., 0]

    pulses = FfbpPulses(
        table_values=table, positions=st.eff_positions, ref_ranges=st.ref_ranges,
        reference_point_m=traces.reference_point_m, constants=tuple(constants), n_up=n_up,
        carrier_hz=st.carrier_hz, bandwidth_hz=float(traces.radar.bandwidth_hz),
    )  # fmt: skip
    return ffbp_values(
        pulses, np.asarray(x_m, np.float64), np.asarray(y_m, np.float64), tile_for=tile_for,
        alpha=alpha, progress=progress, exact_for=exact_for, kernels=_kernels_for(cuda),
    )  # fmt: skip
