"""Where is the mover? Positions fixed by wide-aspect data, tracks per mover: seeded draws.

Regenerate (runs of an aperture each, joined; a 10 degree draw took 10-60 s on a
2-core machine beside other runs, a 4 degree one 5-30 s, a geometric draw seconds)::

    python benchmarks/wide_aspect.py --draws 10 --apertures 4 --name p4a --out /tmp/w
    python benchmarks/wide_aspect.py --first 10 --draws 10 --apertures 4 --name p4b \
        --out /tmp/w
    python benchmarks/wide_aspect.py --draws 8 --apertures 10 --name p10 --out /tmp/w
    python benchmarks/wide_aspect.py --join /tmp/w/p4a.json /tmp/w/p4b.json /tmp/w/p10.json
    python benchmarks/wide_aspect.py --geometric --draws 10 --apertures 4 10 30 90 \
        --name wide_aspect_geometric
    python benchmarks/wide_aspect.py --coherent --draws 20 --apertures 10 30 90 \
        --name wide_aspect_coherent

A 30 degree pass through the whole chain is out of this machine's reach: at GOTCHA's
speed its movers are at most 0.75 m/s (below), and one draw of two such movers gave no
track in 470 s: such a mover's range history is that of a stationary point tens of
metres off in cross range, which each degree's analysis rejects (its stated limit);
90 degrees (160 s of flight) neither. ``--coherent`` measures the focused fit there on
simulated echoes, from looks made from the geometry.

Each draw is a simulated circular pass of GOTCHA's geometry (ground radius 7.1 km,
altitude 7.3 km, 70 m/s, 117 pulses per degree; X band at 9.6 GHz with GOTCHA's 640 MHz
band and 424 frequencies) of 4, 10 or 30 degrees (``--apertures``), imaged over 60 m.

Each scene: 10 stationary points of unit reflectivity uniform in [-25, 25]^2 m; 2
uniform movers of unit reflectivity, speeds uniform in ``[min(1, s_max / 2), s_max]``
m/s with ``s_max = min(8, 40 m / T)`` (``T`` the pass's duration: the movers cross at
most 40 m of the 60 m scene) and headings uniform, drawn again until the range speed at
the pass's centre is outside twice the stationary band's edge ``V S / (2 L)`` (0.21 m/s:
``V`` the platform speed, ``S`` the scene, ``L`` the range; the stationary targets'
apparent range speeds fill the band), positions at the pass's centre such that the
whole path stays within [-25, 25]^2 m, and the movers' ground ranges (x, the range
direction at the pass's centre) at least 3 m (13 range cells) apart over the whole pass:
two movers in one range cell are a detection problem of their own, not this one's
(they would otherwise often share it: a mover that runs along the range direction,
as the band condition favours, has little room in x). At GOTCHA's speed a pass of 30 degrees lasts
53 s, so ``s_max`` is there 0.75 m/s: below the 1-8 m/s of faster movers, which would
leave a 60 m scene (a larger one costs more than this machine gives a benchmark), and
their displacement over the pass is what the position fix uses. 4 degrees: 5.6 m/s,
10 degrees: 2.3 m/s. white noise at 20 dB below each mover's mean power per sample (the
movers' traces' mean power over their number). Seeds ``1000 a + k`` for aperture ``a``
(degrees) and draw ``k``.

Other scenes for the chain: ``--image-m`` (the image's side; points and movers within 5 m
of its edge), ``--pulses-per-deg``, ``--frequencies`` (over GOTCHA's band: a range extent
of ``c N / (2 B)``), ``--max-crossing-m`` and ``--band-factor`` (the movers' range speeds
beyond that many times the stationary band's edge). A mover whose range speed is below
``V W / L`` (``W`` the data's alias-free cross-range extent) has the range history of a
stationary point within that extent, which each degree's analysis rejects (its stated
limit): a 30 degree pass at GOTCHA's speed was run at 200 m, 160 pulses per degree (``W``
205 m), 900 frequencies, movers crossing at most 160 m with range speeds beyond 2.4 times
the band's edge (2.4-3.0 m/s). ``--speckle N`` adds distributed clutter: ``N`` scatterers
uniform over the image, circular Gaussian reflectivities of standard deviation 0.1 (fully
developed speckle), drawn from their own seed so that the points and movers are those of
the draw without it; ``--separation rpca`` separates such clutter (the default method,
made for point scenes, left both movers of a 10 degree draw under g(u)'s threshold
among 2000 scatterers: 2.5 dB against 5.4; rpca found them at 8.4).

Each pass is tracked with :func:`sarmotion.tracking.track` (sub-apertures of a degree,
no overlap, 60 m images, no Dask: ``n_workers=0``). A track belongs to the mover whose
range history its detections match best (mean range difference under 1 m; a track
matching none is a false track). For each mover: its tracks; for its longest track,
the wide-aspect fit's (:mod:`sarmotion.tracking.wide_aspect`) position and velocity at
the pass's centre (``s = 0``) against the truth, the fit's standard deviations, the
Mahalanobis distance of the position error (within 2 sigma: ``d <= 2``, 86.5 % of draws
for a calibrated Gaussian in two dimensions, counted over the fixed positions; and along
the least-known direction alone, ``|e . w| / sigma_w <= 2``, 95.4 %, over all fits),
and whether the fit declares the position fixed or reports the family.

``--geometric`` measures the position part alone, without imaging (seconds a draw, so
that 30 and 90 degrees are within reach): each sub-aperture's detection is made from the
geometry, as the analysis reports it, the member of the mover's cross-range family at the
reference cross range (:func:`sarmotion.motion.aperture.family_member`), moved by errors
drawn with standard deviations :data:`GEOMETRIC_STD` in ground-range position, range speed
and cross-range speed, and given those as its bound. Those are the errors the analysis
made on a simulated 10 degree pass at 20 dB (one mover among 6 points: range errors up
to 8 mm, range-rate errors up to 2e-5 m/s, range-acceleration errors about 1e-3 m/s^2,
i.e. 0.07 m/s of cross-range speed); they are white here, where the analysis's
range-acceleration errors shared a sign, so this mode is the fit's own accuracy, not
the chain's. Movers as above but 1-8 m/s at every aperture (nothing is imaged), the
antenna at 30 pulses per degree. Each mover's detections are also cut into three
pieces that must join into one track, and its middle piece set against the other
mover's to see that they do not (:func:`sarmotion.tracking.wide_aspect.join_tracks`).

``--coherent`` measures the coherent refinement (:mod:`sarmotion.tracking.coherent`):
each draw a pass of 117 pulses per degree holding one uniform mover (1-8 m/s, within
25 m of the centre at the pass's centre) and 10 unit points, noise 20 dB below the
mover's power per sample; the looks' fit from detections made as in ``--geometric`` on
the same pass; where it fixes the position, the simulated traces focused over every
pulse, scored at the pass's centre against the looks' fit. Seeds ``1000 a + 800 + k``.

``--turns`` measures the turn tests (:mod:`sarmotion.tracking.turns`) on the same
seeded tracks, each draw a uniform mover and one turning at 3 deg/s (either sense),
1-8 m/s, headings uniform, made as in ``--geometric`` at the mover's state at each
sub-aperture's centre (the range component of its acceleration added to the measured
range acceleration) for sub-apertures of a degree overlapping by ``--overlaps``: errors
of :data:`GEOMETRIC_STD` correlated as overlapping windows' are (each window's error the
normalised sum of the independent errors of the steps it spans), bounds
:data:`TURN_FACTORS` times smaller (the medians of the a posteriori factors through the
whole chain at 4 degrees: the clutter residue). Both the looks' test
(:func:`~sarmotion.tracking.turns.look_turn_test`) and the pairs' test
(:func:`~sarmotion.tracking.turns.turn_test`, the rule before) at ``p`` = 0.01; seeds
``1000 a + 500 + k``; the turn rate in the ground frame
(:mod:`sarmotion.tracking.turn_rate`) and its 95 % interval on every track (the tracker
fits it only where the position is fixed). Through the whole chain (the default mode)
each track's test is the tracker's, with the pairs' beside it (``turn_flagged_pairs``).
Regenerate::

    python benchmarks/wide_aspect.py --turns --draws 7 --apertures 4 10 20 30 40 \
        --name wide_aspect_turns

Writes ``<name>.json`` and ``<name>.md`` under ``--out`` (``--name``, default
``wide_aspect``); ``--join`` merges runs made aperture by aperture.
"""

from __future__ import annotations

import argparse
import json
import time
from pathlib import Path

import numpy as np
from scipy.stats import chi2

from sarmotion.motion.aperture import azimuth_span_deg
from sarmotion.pipeline import AnalysisOptions
from sarmotion.separation import SeparationOptions
from sarmotion.simulation import PointTarget, Scene, load_scene, simulate
from sarmotion.tracking import TrackingOptions, track
from sarmotion.tracking.wide_aspect import antenna_state, range_history

SPEED_MPS = 70.0
PULSES_PER_DEG = 117
RANGE_M = float(np.hypot(7100.0, 7300.0))
IMAGE_M = 60.0
HALF_SCENE_M = 25.0
MAX_CROSSING_M = 40.0
N_CLUTTER = 10
N_MOVERS = 2
SNR_DB = 20.0
MATCH_RANGE_M = 1.0
MIN_RANGE_GAP_M = 3.0
#: Detection errors of the geometric mode: ground-range position (m), range speed and
#: cross-range speed (m/s) (module notes).
GEOMETRIC_STD = np.array([5e-3, 2e-5, 0.07])
GEOMETRIC_PULSES_PER_DEG = 30


#: Movers' range speeds at the pass's centre exceed this many times the stationary band's
#: edge (``--band-factor``; module notes).
BAND_FACTOR = 2.0

#: Frequencies of the chain's radar over GOTCHA's band (``--frequencies``; its range
#: extent ``c N / (2 B)``, 99 m at GOTCHA's 424).
N_FREQUENCIES = 424


#: Distributed clutter of the chain (``--speckle N``): N scatterers uniform over the
#: image, circular Gaussian reflectivities of standard deviation SPECKLE_AMPLITUDE
#: (fully developed speckle), drawn apart from the points and movers (seed + 13).
SPECKLE_N = 0
SPECKLE_AMPLITUDE = 0.1

#: The chain's separation method (``--separation``; None: the analysis's default).
SEPARATION: str | None = None


def _speckle(seed: int) -> list[PointTarget]:
    """The draw's distributed clutter (:data:`SPECKLE_N` scatterers; none by default)."""
    if SPECKLE_N == 0:
        return []
    rng = np.random.default_rng(seed + 13)
    refl = rng.standard_normal(SPECKLE_N) + 1j * rng.standard_normal(SPECKLE_N)
    where = rng.uniform(-0.5 * IMAGE_M, 0.5 * IMAGE_M, (SPECKLE_N, 2))
    return [
        PointTarget(position_m=p, reflectivity=complex(SPECKLE_AMPLITUDE * r / np.sqrt(2.0)))
        for p, r in zip(where, refl, strict=True)
    ]


def _radar(radar):
    """``radar`` with :data:`N_FREQUENCIES` frequencies over the same band."""
    if N_FREQUENCIES == radar.n_samples:
        return radar
    import dataclasses

    return dataclasses.replace(
        radar, n_samples=N_FREQUENCIES, frequency_step_hz=radar.bandwidth_hz / N_FREQUENCIES
    )


def configure(
    image_m: float,
    pulses_per_deg: int,
    frequencies: int,
    max_crossing_m: float,
    band_factor: float = 2.0,
    speckle: int = 0,
    separation: str | None = None,
):
    """The chain's scene for other sizes (``--image-m`` and the options beside it).

    The movers and points are drawn within 5 m of the image's edge.
    """
    global IMAGE_M, HALF_SCENE_M, PULSES_PER_DEG, N_FREQUENCIES, MAX_CROSSING_M, BAND_FACTOR
    IMAGE_M, HALF_SCENE_M = float(image_m), 0.5 * float(image_m) - 5.0
    PULSES_PER_DEG, N_FREQUENCIES = int(pulses_per_deg), int(frequencies)
    MAX_CROSSING_M, BAND_FACTOR = float(max_crossing_m), float(band_factor)
    global SPECKLE_N, SEPARATION
    SPECKLE_N, SEPARATION = int(speckle), separation


def draw_scene(aperture_deg: float, seed: int) -> tuple[Scene, list[PointTarget], float]:
    """A seeded scene (module notes): the scene, its movers and the pass's duration (s)."""
    rng = np.random.default_rng(seed)
    base = load_scene("scene1")
    duration = np.deg2rad(aperture_deg) * 7100.0 / SPEED_MPS
    top = min(8.0, MAX_CROSSING_M / duration)
    clutter = [
        PointTarget(
            position_m=rng.uniform(-HALF_SCENE_M, HALF_SCENE_M, 2),
            reflectivity=complex(np.exp(2j * np.pi * rng.uniform())),
        )
        for _ in range(N_CLUTTER)
    ]
    look = np.array([7100.0, 0.0]) / RANGE_M  # ground part of m_o at the pass's centre
    band = SPEED_MPS * IMAGE_M / (2.0 * RANGE_M)  # stationary band's edge (module notes)
    if top * float(np.linalg.norm(look)) <= BAND_FACTOR * band:  # else the draws never end
        raise ValueError(
            f"{aperture_deg:g} degrees: no mover crosses at most {MAX_CROSSING_M:g} m "
            f"({top:.2f} m/s) with a range speed beyond {BAND_FACTOR:g} times the stationary "
            f"band ({BAND_FACTOR * band:.2f} m/s)"
        )
    movers: list[PointTarget] = []
    times = np.linspace(-duration / 2.0, duration / 2.0, 21)
    for k in range(N_MOVERS):
        while True:
            while True:  # range speed outside BAND_FACTOR times the stationary band
                speed = rng.uniform(min(1.0, top / 2.0), top)
                heading = rng.uniform(0.0, 2.0 * np.pi)
                u = speed * np.array([np.cos(heading), np.sin(heading)])
                if abs(u @ look) > BAND_FACTOR * band:
                    break
            reach = np.abs(u) * duration / 2.0
            p = rng.uniform(-HALF_SCENE_M + reach, HALF_SCENE_M - reach)
            # ground ranges apart by MIN_RANGE_GAP_M over the whole pass
            if all(
                np.min(np.abs((p[0] - m.position_m[0]) + times * (u[0] - m.velocity_mps[0])))
                >= MIN_RANGE_GAP_M
                for m in movers
            ):
                break
        movers.append(
            PointTarget(
                position_m=p,
                velocity_mps=u,
                reflectivity=complex(np.exp(2j * np.pi * rng.uniform())),
                label=f"mover {k + 1}",
            )
        )
    speckle = _speckle(seed)
    scene = Scene(
        name=f"wide{aperture_deg:g}-{seed}",
        targets=(*clutter, *speckle, *movers),
        radar=_radar(base.radar),
        trajectory_spec={
            "kind": "circular",
            "aperture_deg": float(aperture_deg),
            "pulses_per_deg": PULSES_PER_DEG,
            "speed_mps": SPEED_MPS,
        },
    )
    return scene, movers, float(duration)


def noisy_traces(scene: Scene, n_movers: int, seed: int):
    """The scene's traces with noise 20 dB below each mover's mean power per sample."""
    sim = simulate(scene)
    power = float(np.mean(np.abs(sim.moving) ** 2)) / n_movers
    sigma = np.sqrt(power / 10.0 ** (SNR_DB / 10.0) / 2.0)
    rng = np.random.default_rng(seed + 7)
    noise = sigma * (
        rng.standard_normal(sim.traces.data.shape) + 1j * rng.standard_normal(sim.traces.data.shape)
    )
    return sim.traces.with_data(sim.traces.data + noise)


def _range_mismatch(trk, mover: PointTarget, traces, pulses: dict[int, slice]) -> float:
    """Mean |range of the detection - range of the mover| over a track's detections (m)."""
    diffs = []
    u = np.asarray(mover.velocity_mps, dtype=np.float64)
    p0 = np.asarray(mover.position_m, dtype=np.float64)[:2]
    for s in trk.states:
        if s.detection is None:
            continue
        a = antenna_state(traces, pulses[s.sub_aperture], s.time_s)
        z = range_history(s.detection.position_m, s.detection.velocity_mps, a)
        t = range_history(p0 + s.time_s * u, u, a)
        diffs.append(abs(z[0] - t[0]))
    return float(np.mean(diffs)) if diffs else np.inf


def _pairs_flagged(trk, pulses: dict[int, slice]) -> bool | None:
    """The pairs' turn test (the rule before the looks', ``turns.turn_test``) of a track."""
    from sarmotion.tracking.turns import turn_test

    hits = [s for s in trk.states if s.detection is not None]
    if len(hits) < 2 or any(s.detection.velocity_cov_m2ps2 is None for s in hits):
        return None
    res = turn_test(
        [s.time_s for s in hits],
        [(pulses[s.sub_aperture].start, pulses[s.sub_aperture].stop) for s in hits],
        [s.detection.position_m for s in hits], [s.detection.velocity_mps for s in hits],
        [s.detection.velocity_cov_m2ps2 for s in hits],
        ([s.detection.family_position_per_m for s in hits],
         [s.detection.family_velocity_per_m for s in hits]),
        false_alarm=TURN_FALSE_ALARM,
    )  # fmt: skip
    return bool(res.flagged)


def run_draw(aperture_deg: float, seed: int) -> dict:
    """One seeded pass, tracked and scored (module notes)."""
    scene, movers, duration = draw_scene(aperture_deg, seed)
    traces = noisy_traces(scene, len(movers), seed)
    opts = TrackingOptions(
        overlap=0.0,
        analysis=AnalysisOptions(
            trajectory=False,
            image_size_m=IMAGE_M,
            separation=SeparationOptions(method=SEPARATION),
        ),  # fmt: skip
    )
    start = time.perf_counter()
    result = track(traces, opts, n_workers=0)
    seconds = time.perf_counter() - start
    pulses = {s.index: s.pulses for s in result.sub_apertures}
    owner = []
    for trk in result.tracks:
        mismatch = [_range_mismatch(trk, m, traces, pulses) for m in movers]
        k = int(np.argmin(mismatch))
        owner.append(k if mismatch[k] < MATCH_RANGE_M else None)
    out_movers = []
    for k, m in enumerate(movers):
        mine = [t for t, o in zip(result.tracks, owner, strict=True) if o == k]
        rec: dict = {
            "position_m": np.asarray(m.position_m)[:2].tolist(),
            "velocity_mps": np.asarray(m.velocity_mps).tolist(),
            "speed_mps": float(np.hypot(*m.velocity_mps)),
            "n_tracks": len(mine),
            "n_detections": [t.n_detections for t in mine],
            "turn_flagged": [bool(t.turn.flagged) if t.turn else None for t in mine],
            "turn_model": [t.turn.model if t.turn else None for t in mine],
            "turn_flagged_pairs": [_pairs_flagged(t, pulses) for t in mine],
            "ground_turn_rate": [_ground_rate(t) for t in mine],
        }
        if mine:
            best = max(mine, key=lambda t: t.n_detections)
            fit = best.fit
            if fit is not None:
                x, cov = fit.at(0.0)
                e = x[:2] - np.asarray(m.position_m)[:2]
                ev = x[2:] - np.asarray(m.velocity_mps)
                w, v = np.linalg.eigh(cov[:2, :2])
                d = float(np.sqrt(e @ np.linalg.solve(cov[:2, :2], e)))
                rec.update(
                    fixed=fit.fixed,
                    fitted_position_m=x[:2].tolist(),
                    fitted_velocity_mps=x[2:].tolist(),
                    position_error_m=float(np.hypot(*e)),
                    velocity_error_mps=float(np.hypot(*ev)),
                    position_std_m=float(np.sqrt(w[-1])),
                    position_std_min_m=float(np.sqrt(max(w[0], 0.0))),
                    velocity_std_mps=float(np.sqrt(np.linalg.eigvalsh(cov[2:, 2:])[-1])),
                    mahalanobis=d,
                    worst_axis_sigmas=float(abs(e @ v[:, -1]) / np.sqrt(w[-1])),
                    chi2=fit.chi2,
                    dof=fit.dof,
                    error_factors=fit.error_factors.tolist(),
                    aspect_deg=fit.aspect_deg,
                )
            if best.coherent is not None:
                rec["coherent"] = _coherent_record(best.coherent, m)
        out_movers.append(rec)
    return {
        "aperture_deg": aperture_deg,
        "measured_span_deg": azimuth_span_deg(traces),
        "seed": seed,
        "duration_s": duration,
        "n_sub_apertures": len(result.sub_apertures),
        "n_tracks": len(result.tracks),
        "false_tracks": sum(o is None for o in owner),
        "movers": out_movers,
        "seconds": seconds,
    }


def _coherent_record(fit, mover: PointTarget) -> dict:
    """A track's coherent refinement scored at the pass's centre (``s = 0``)."""
    dt = -fit.time_s
    f = np.eye(4)
    f[0, 2] = f[1, 3] = dt
    x = f @ fit.state
    e = x[:2] - np.asarray(mover.position_m)[:2]
    out = {
        "position_error_m": float(np.hypot(*e)),
        "velocity_error_mps": float(np.hypot(*(x[2:] - np.asarray(mover.velocity_mps)))),
        "position_bound_m": fit.position_bound_m,
        "coherence": fit.coherence,
        "coherent": fit.coherent,
        "error_factor": fit.error_factor if np.isfinite(fit.error_factor) else None,
        "position_std_m": None,
        "mahalanobis": None,
    }
    if np.isfinite(fit.error_factor):
        cov = f @ fit.covariance @ f.T
        out["position_std_m"] = float(np.sqrt(np.linalg.eigvalsh(cov[:2, :2])[-1]))
        out["mahalanobis"] = float(np.sqrt(e @ np.linalg.solve(cov[:2, :2], e)))
    return out


def _ground_rate(trk) -> dict | None:
    """A track's turn rate in the ground frame (where its position is fixed), or None."""
    rate = trk.turn.turn_rate if trk.turn is not None else None
    if rate is None:
        return None
    return {
        "rate_deg_s": rate.rate_deg_s,
        "interval_deg_s": list(rate.interval_deg_s),
        "fixed": rate.fixed,
    }


def _geometric_looks(traces, mover: PointTarget, rng) -> list:
    """Detections of ``mover`` made from the geometry (module notes), one per degree."""
    from sarmotion.core import ground_velocity
    from sarmotion.imaging import resolution
    from sarmotion.motion.aperture import family_direction, family_member
    from sarmotion.tracking import Detection
    from sarmotion.tracking.sub_apertures import sub_aperture_slices, sub_aperture_time_s
    from sarmotion.tracking.wide_aspect import look_measurement

    p0 = np.asarray(mover.position_m, dtype=np.float64)[:2]
    u = np.asarray(mover.velocity_mps, dtype=np.float64)
    looks = []
    for k, sl in enumerate(sub_aperture_slices(traces, 1.0, 0.0)):
        sub_traces = traces.select_pulses(sl.start, sl.stop)
        t_c = sub_aperture_time_s(traces, sl)
        geom = sub_traces.geometry
        cells = resolution(sub_traces)
        p_c = p0 + t_c * u
        p, v, _ = family_member(
            sub_traces, np.r_[p_c, 0.0], u, -float(p_c @ cells.cross_range_direction)
        )
        e = rng.standard_normal(3) * GEOMETRIC_STD
        p = p[:2] + e[0] * cells.range_direction
        v = v + e[1] * ground_velocity(1.0, 0.0, geom) + e[2] * ground_velocity(0.0, 1.0, geom)
        a, b = family_direction(sub_traces, np.r_[p, 0.0], v)
        row = (geom.tangent @ geom.projector)[:2]
        det = Detection(
            position_m=p, velocity_mps=v, range_speed_mps=float(v @ geom.m_o[:2]),
            cross_range_speed_mps=float(v @ row), family_position_per_m=a,
            family_velocity_per_m=b, peak_db=0.0, traces=None,
            bound_cov=np.diag(GEOMETRIC_STD**2),
        )  # fmt: skip
        sub = _GeometricSub(
            index=k, look_direction=np.asarray(geom.m_o, dtype=np.float64),
            range_direction=np.asarray(cells.range_direction, dtype=np.float64),
            cross_range_speed_row=row,
        )  # fmt: skip
        looks.append(look_measurement(sub, det, antenna_state(traces, sl, t_c)))  # type: ignore[arg-type]
    return looks


class _GeometricSub:
    """The fields of a sub-aperture record that a look measurement reads."""

    def __init__(self, **fields) -> None:
        self.__dict__.update(fields)


def _circular_scene(aperture_deg: float, targets=(), pulses_per_deg: int | None = None):
    """A circular pass of GOTCHA's geometry holding ``targets`` (default none).

    ``pulses_per_deg``: default the geometric modes' :data:`GEOMETRIC_PULSES_PER_DEG`.
    """
    return Scene(
        name="pass", targets=tuple(targets), radar=load_scene("scene1").radar,
        trajectory_spec={
            "kind": "circular", "aperture_deg": float(aperture_deg),
            "pulses_per_deg": pulses_per_deg or GEOMETRIC_PULSES_PER_DEG,
            "speed_mps": SPEED_MPS,
        },
    )  # fmt: skip


def _empty_pass(aperture_deg: float):
    """The traces of a circular pass with no target, at the geometric modes' pulse rate."""
    return simulate(_circular_scene(aperture_deg)).traces


def run_geometric(aperture_deg: float, seed: int) -> dict:
    """One seeded geometric draw (module notes): fits, and joins of pieces."""
    from sarmotion.tracking.wide_aspect import fit_track, join_tracks, pooled_factors

    traces = _empty_pass(aperture_deg)
    duration = np.deg2rad(aperture_deg) * 7100.0 / SPEED_MPS
    rng = np.random.default_rng(seed)
    movers = []
    for _ in range(N_MOVERS):  # 1-8 m/s, headings uniform: nothing is imaged
        speed, heading = rng.uniform(1.0, 8.0), rng.uniform(0.0, 2.0 * np.pi)
        u = speed * np.array([np.cos(heading), np.sin(heading)])
        movers.append(
            PointTarget(position_m=rng.uniform(-HALF_SCENE_M, HALF_SCENE_M, 2), velocity_mps=u)
        )
    start = time.perf_counter()
    prior = {"prior_std_m": IMAGE_M / 2.0}
    looks = [_geometric_looks(traces, m, rng) for m in movers]
    out_movers = []
    for m, mine in zip(movers, looks, strict=True):
        fit = fit_track(mine, wavelength_m=float(traces.radar.wavelength_m), **prior)
        x, cov = fit.at(0.0)
        e = x[:2] - np.asarray(m.position_m)[:2]
        w, v = np.linalg.eigh(cov[:2, :2])
        third = max(1, len(mine) // 3)
        pieces = [mine[:third], mine[third : 2 * third], mine[2 * third :]]
        pieces = [p for p in pieces if p]
        factors = pooled_factors(pieces, **prior)
        joined = join_tracks(pieces, gate_probability=0.999, error_factors=factors, **prior)
        out_movers.append(
            {
                "position_m": np.asarray(m.position_m)[:2].tolist(),
                "velocity_mps": np.asarray(m.velocity_mps).tolist(),
                "speed_mps": float(np.hypot(*m.velocity_mps)),
                "n_tracks": len(joined),
                "n_detections": [len(mine)],
                "turn_flagged": [],
                "fixed": fit.fixed,
                "position_error_m": float(np.hypot(*e)),
                "velocity_error_mps": float(np.hypot(*(x[2:] - m.velocity_mps))),
                "position_std_m": float(np.sqrt(w[-1])),
                "position_std_min_m": float(np.sqrt(max(w[0], 0.0))),
                "velocity_std_mps": float(np.sqrt(np.linalg.eigvalsh(cov[2:, 2:])[-1])),
                "mahalanobis": float(np.sqrt(e @ np.linalg.solve(cov[:2, :2], e))),
                "worst_axis_sigmas": float(abs(e @ v[:, -1]) / np.sqrt(w[-1])),
                "chi2": fit.chi2,
                "dof": fit.dof,
                "error_factors": fit.error_factors.tolist(),
                "aspect_deg": fit.aspect_deg,
            }
        )
    # the middle pieces of the two movers: never one track
    mids = [g[len(g) // 3 : 2 * len(g) // 3] for g in looks]
    crossed = join_tracks(
        [looks[0][: len(looks[0]) // 3], mids[1]], gate_probability=0.999, **prior
    )
    return {
        "aperture_deg": aperture_deg,
        "measured_span_deg": azimuth_span_deg(traces),
        "seed": seed,
        "duration_s": duration,
        "n_sub_apertures": len(looks[0]),
        "n_tracks": sum(m["n_tracks"] for m in out_movers),
        "false_tracks": 0,
        "movers_joined_wrongly": len(crossed) < 2,
        "movers": out_movers,
        "seconds": time.perf_counter() - start,
    }


def run_coherent(aperture_deg: float, seed: int) -> dict:
    """One seeded ``--coherent`` draw (module notes): a mover's fit, then its echo focused."""
    from sarmotion.tracking.coherent import refine_coherently
    from sarmotion.tracking.sub_apertures import sub_aperture_slices
    from sarmotion.tracking.wide_aspect import fit_track

    rng = np.random.default_rng(seed)
    speed, heading = rng.uniform(1.0, 8.0), rng.uniform(0.0, 2.0 * np.pi)
    mover = PointTarget(
        position_m=rng.uniform(-HALF_SCENE_M, HALF_SCENE_M, 2),
        velocity_mps=speed * np.array([np.cos(heading), np.sin(heading)]),
        reflectivity=complex(np.exp(2j * np.pi * rng.uniform())),
    )
    clutter = [
        PointTarget(
            position_m=rng.uniform(-HALF_SCENE_M, HALF_SCENE_M, 2),
            reflectivity=complex(np.exp(2j * np.pi * rng.uniform())),
        )
        for _ in range(N_CLUTTER)
    ]
    scene = _circular_scene(aperture_deg, (*clutter, mover), PULSES_PER_DEG)
    traces = noisy_traces(scene, 1, seed)
    start = time.perf_counter()
    looks = _geometric_looks(traces, mover, rng)
    fit = fit_track(looks, prior_std_m=IMAGE_M / 2.0, wavelength_m=float(traces.radar.wavelength_m))
    rec: dict = {
        "aperture_deg": aperture_deg, "seed": seed, "speed_mps": float(speed),
        "fixed": fit.fixed, "fit_position_std_m": fit.position_std_at(0.0),
    }  # fmt: skip
    x, _ = fit.at(0.0)
    rec["fit_position_error_m"] = float(np.hypot(*(x[:2] - np.asarray(mover.position_m)[:2])))
    if fit.fixed:
        focused = refine_coherently(traces, fit, sub_aperture_slices(traces, 1.0, 0.0))
        rec["coherent"] = _coherent_record(focused, mover)
    rec["seconds"] = time.perf_counter() - start
    return rec


def summarise_coherent(draws: list[dict]) -> dict:
    """Figures of the ``--coherent`` draws of one aperture."""
    focused = [d["coherent"] for d in draws if d.get("coherent")]
    measured = [c for c in focused if c["mahalanobis"] is not None]

    def med(key, items):
        vals = [c[key] for c in items if c[key] is not None]
        return float(np.median(vals)) if vals else None

    return {
        "draws": len(draws),
        "fixed": sum(d["fixed"] for d in draws),
        "fit_position_error_median_m": float(
            np.median([d["fit_position_error_m"] for d in draws if d["fixed"]])
        ) if any(d["fixed"] for d in draws) else None,
        "fit_position_std_median_m": float(
            np.median([d["fit_position_std_m"] for d in draws if d["fixed"]])
        ) if any(d["fixed"] for d in draws) else None,
        "coherent": sum(c["coherent"] for c in focused),
        "position_error_median_m": med("position_error_m", focused),
        "position_error_max_m": max((c["position_error_m"] for c in focused), default=None),
        "velocity_error_max_mps": max((c["velocity_error_mps"] for c in focused), default=None),
        "position_std_median_m": med("position_std_m", focused),
        "position_bound_median_m": med("position_bound_m", focused),
        "error_factor_median": med("error_factor", measured),
        "within_2sigma": sum(c["mahalanobis"] <= 2.0 for c in measured),
        "measured": len(measured),
        "seconds_median": float(np.median([d["seconds"] for d in draws])),
    }  # fmt: skip


def main_coherent(args: argparse.Namespace) -> int:
    """``--coherent``: seeded draws per aperture (module notes)."""
    draws: dict[str, list[dict]] = {}
    for ap in args.apertures:
        key = f"{ap:g}"
        draws[key] = [run_coherent(ap, int(1000 * ap) + 800 + k)
                      for k in range(args.first, args.first + args.draws)]  # fmt: skip
        print(key, [(d["fixed"], d.get("coherent", {}).get("position_error_m"))
                    for d in draws[key]], flush=True)  # fmt: skip
    summary = {key: summarise_coherent(d) for key, d in draws.items()}
    doc = {
        "settings": {
            "pulses_per_deg": PULSES_PER_DEG, "n_clutter": N_CLUTTER, "snr_db": SNR_DB,
            "geometric_std": GEOMETRIC_STD.tolist(), "speed_mps": SPEED_MPS,
        },
        "summary": summary,
        "draws": draws,
    }  # fmt: skip
    (args.out / f"{args.name}.json").write_text(json.dumps(doc, indent=1) + "\n")

    def f(x, fmt="{:.4f}"):
        return "-" if x is None else fmt.format(x)

    rows = [
        "| aperture | draws | looks' fit fixed | its error, std (median) | coherent "
        "| focused error (median, max) | std (median) | bound (median) "
        "| error factor (median) | within 2 sigma (2-D) | velocity error (max) | time (median) |",
        "|---|---|---|---|---|---|---|---|---|---|---|---|",
    ]
    for key, v in summary.items():
        rows.append(
            f"| {key} deg | {v['draws']} | {v['fixed']} "
            f"| {f(v['fit_position_error_median_m'])}, {f(v['fit_position_std_median_m'])} m "
            f"| {v['coherent']}/{v['fixed']} "
            f"| {f(v['position_error_median_m'])}, {f(v['position_error_max_m'])} m "
            f"| {f(v['position_std_median_m'])} m | {f(v['position_bound_median_m'])} m "
            f"| {f(v['error_factor_median'], '{:.1f}')} | {v['within_2sigma']}/{v['measured']} "
            f"| {f(v['velocity_error_max_mps'], '{:.5f}')} m/s "
            f"| {f(v['seconds_median'], '{:.1f}')} s |"
        )
    (args.out / f"{args.name}.md").write_text("\n".join(rows) + "\n")
    print("\n".join(rows))
    return 0


#: A posteriori factors of the turn mode's errors over their bounds (range, range rate,
#: range acceleration): the medians through the whole chain at 4 degrees (module notes).
TURN_FACTORS = np.array([5.0, 3.0, 11.0])
TURN_RATE_DEG_S = 3.0


def _moving_looks(traces, motion, rng, overlap: float, factors) -> tuple[list, list, list]:
    """Detections of a mover of ``motion(t) -> (p, u, a)`` over sub-apertures of a degree.

    Made as in ``--geometric`` at the mover's state at each centre time, with errors of
    :data:`GEOMETRIC_STD` correlated as overlapping windows' are (each window's error the
    normalised sum of independent errors of the steps it spans: neighbours correlated
    by ``overlap``), bounds ``factors`` times smaller, and the range component of the
    mover's acceleration added to the measured ``R''``. Returns the look measurements,
    the pulses and the detections.
    """
    import dataclasses

    from sarmotion.core import ground_velocity
    from sarmotion.imaging import resolution
    from sarmotion.motion.aperture import family_direction, family_member
    from sarmotion.tracking import Detection
    from sarmotion.tracking.sub_apertures import sub_aperture_slices, sub_aperture_time_s
    from sarmotion.tracking.wide_aspect import look_measurement

    slices = sub_aperture_slices(traces, 1.0, overlap)
    span = max(1, round(1.0 / (1.0 - overlap)))
    steps = rng.standard_normal((len(slices) + span, 3))
    bound = GEOMETRIC_STD / np.asarray(factors)
    looks, pulses, dets = [], [], []
    for k, sl in enumerate(slices):
        sub_traces = traces.select_pulses(sl.start, sl.stop)
        t_c = sub_aperture_time_s(traces, sl)
        geom = sub_traces.geometry
        cells = resolution(sub_traces)
        p_c, u_c, a_c = motion(t_c)
        p, v, _ = family_member(
            sub_traces, np.r_[p_c, 0.0], u_c, -float(p_c @ cells.cross_range_direction)
        )
        e = steps[k : k + span].sum(axis=0) / np.sqrt(span) * GEOMETRIC_STD
        p = p[:2] + e[0] * cells.range_direction
        b_r, b_p = ground_velocity(1.0, 0.0, geom), ground_velocity(0.0, 1.0, geom)
        v = v + e[1] * b_r + e[2] * b_p
        a, b = family_direction(sub_traces, np.r_[p, 0.0], v)
        row = (geom.tangent @ geom.projector)[:2]
        speeds = np.column_stack([b_r, b_p])
        det = Detection(
            position_m=p, velocity_mps=v, range_speed_mps=float(v @ geom.m_o[:2]),
            cross_range_speed_mps=float(v @ row), family_position_per_m=a,
            family_velocity_per_m=b, peak_db=0.0, traces=None,
            velocity_cov_m2ps2=speeds @ np.diag(bound[1:] ** 2) @ speeds.T,
            bound_cov=np.diag(bound**2),
        )  # fmt: skip
        sub = _GeometricSub(
            index=k, look_direction=np.asarray(geom.m_o, dtype=np.float64),
            range_direction=np.asarray(cells.range_direction, dtype=np.float64),
            cross_range_speed_row=row,
        )  # fmt: skip
        antenna = antenna_state(traces, sl, t_c)
        look = look_measurement(sub, det, antenna, overlap=overlap)  # type: ignore[arg-type]
        d = np.r_[p_c, 0.0] - antenna.position_m
        z = look.z + np.array([0.0, 0.0, float(np.r_[a_c, 0.0] @ d) / float(np.linalg.norm(d))])
        looks.append(dataclasses.replace(look, z=z))
        pulses.append((sl.start, sl.stop))
        dets.append((t_c, det))
    return looks, pulses, dets


def run_turns(aperture_deg: float, seed: int, overlap: float) -> dict:
    """One seeded turn draw: a uniform mover and one turning at 3 deg/s, both tests."""
    from sarmotion.tracking.turns import look_turn_test, turn_test

    rng = np.random.default_rng(seed + 11)
    traces = _empty_pass(aperture_deg)  # the pass alone: its movers are drawn below
    out = {"aperture_deg": aperture_deg, "seed": seed, "overlap": overlap, "tracks": []}
    for rate in (0.0, TURN_RATE_DEG_S):
        speed, heading = rng.uniform(1.0, 8.0), rng.uniform(0.0, 2.0 * np.pi)
        p0 = rng.uniform(-HALF_SCENE_M, HALF_SCENE_M, 2)
        w = np.radians(rate) * rng.choice([-1.0, 1.0])

        def motion(t, p0=p0, speed=speed, heading=heading, w=w):
            th = heading + w * t
            u = speed * np.array([np.cos(th), np.sin(th)])
            if w == 0.0:
                return p0 + t * u, u, np.zeros(2)
            p = p0 + speed / w * np.array([np.sin(th) - np.sin(heading),
                                           np.cos(heading) - np.cos(th)])  # fmt: skip
            return p, u, w * speed * np.array([-np.sin(th), np.cos(th)])

        looks, pulses, dets = _moving_looks(traces, motion, rng, overlap, TURN_FACTORS)
        start = time.perf_counter()
        new = look_turn_test(looks, pulses, false_alarm=TURN_FALSE_ALARM,
                             prior_std_m=IMAGE_M / 2.0, rate=True)  # fmt: skip
        ground = new.turn_rate if new else None
        seconds = time.perf_counter() - start
        old = turn_test(
            [t for t, _ in dets], pulses, [d.position_m for _, d in dets],
            [d.velocity_mps for _, d in dets], [d.velocity_cov_m2ps2 for _, d in dets],
            ([d.family_position_per_m for _, d in dets],
             [d.family_velocity_per_m for _, d in dets]),
            false_alarm=TURN_FALSE_ALARM,
        )  # fmt: skip
        out["tracks"].append(
            {
                "turn_rate_deg_s": float(np.degrees(w)),
                "speed_mps": float(speed),
                "flagged": bool(new.flagged) if new else None,
                "statistic": new.statistic if new else None,
                "threshold": new.threshold if new else None,
                "n_looks": new.n_looks if new else 0,
                "ground_rate_deg_s": ground.rate_deg_s if ground else None,
                "ground_rate_interval_deg_s": list(ground.interval_deg_s) if ground else None,
                "ground_rate_fixed": ground.fixed if ground else None,
                "old_flagged": bool(old.flagged),
                "old_statistic": old.statistic,
                "old_threshold": old.threshold,
                "seconds": seconds,
            }
        )
    return out


TURN_FALSE_ALARM = 0.01


def summarise_turns(draws: list[dict]) -> dict:
    """Flag rates of the two tests over uniform and turning tracks."""
    tracks = [t for d in draws for t in d["tracks"]]
    uni = [t for t in tracks if t["turn_rate_deg_s"] == 0.0]
    turn = [t for t in tracks if t["turn_rate_deg_s"] != 0.0]
    rated = [t for t in tracks if t.get("ground_rate_interval_deg_s")]
    fixed = [t for t in rated if t["ground_rate_fixed"]]

    def covered(t):
        lo, hi = t["ground_rate_interval_deg_s"]
        return lo <= t["turn_rate_deg_s"] <= hi

    widths = [np.diff(t["ground_rate_interval_deg_s"])[0] for t in fixed]
    return {
        "uniform_tracks": len(uni),
        "uniform_flagged": sum(bool(t["flagged"]) for t in uni),
        "uniform_flagged_old": sum(t["old_flagged"] for t in uni),
        "turning_tracks": len(turn),
        "turning_flagged": sum(bool(t["flagged"]) for t in turn),
        "turning_flagged_old": sum(t["old_flagged"] for t in turn),
        "ground_rate_tracks": len(rated),
        "ground_rate_fixed": len(fixed),
        "ground_rate_covered": sum(covered(t) for t in rated),
        "ground_rate_fixed_covered": sum(covered(t) for t in fixed),
        "ground_rate_fixed_width_median_deg_s": float(np.median(widths)) if widths else None,
        "ground_rate_fixed_error_max_deg_s": max(
            (abs(t["ground_rate_deg_s"] - t["turn_rate_deg_s"]) for t in fixed), default=None
        ),
        "untested": sum(t["flagged"] is None for t in tracks),
    }


def summarise(draws: list[dict]) -> dict:
    """Per-aperture figures of the draws."""
    movers = [m for d in draws for m in d["movers"]]
    fitted = [m for m in movers if "fixed" in m]
    fixed = [m for m in fitted if m["fixed"]]
    detected = [m for m in movers if m["n_tracks"] > 0]
    rates = [r for m in movers for r in m.get("ground_turn_rate", []) if r]
    focused = [m["coherent"] for m in movers if m.get("coherent")]
    measured = [c for c in focused if c["mahalanobis"] is not None]

    def median(key, items):
        return float(np.median([m[key] for m in items])) if items else None

    return {
        "draws": len(draws),
        "movers": len(movers),
        "movers_tracked": len(detected),
        "one_track_share": (sum(m["n_tracks"] == 1 for m in detected) / len(detected))
        if detected else None,
        "tracks_per_tracked_mover": float(np.mean([m["n_tracks"] for m in detected]))
        if detected else None,
        "false_tracks": int(sum(d["false_tracks"] for d in draws)),
        "fixed": len(fixed),
        "family": len(fitted) - len(fixed),
        "fixed_position_error_median_m": median("position_error_m", fixed),
        "fixed_position_error_max_m": max((m["position_error_m"] for m in fixed), default=None),
        "fixed_velocity_error_median_mps": median("velocity_error_mps", fixed),
        "fixed_velocity_error_max_mps": max((m["velocity_error_mps"] for m in fixed), default=None),
        "fixed_position_std_median_m": median("position_std_m", fixed),
        "within_2sigma_share": (sum(m["mahalanobis"] <= 2.0 for m in fixed) / len(fixed))
        if fixed else None,
        "within_2sigma_worst_axis_share": (
            sum(m["worst_axis_sigmas"] <= 2.0 for m in fitted) / len(fitted)
        ) if fitted else None,
        "family_position_std_median_m": median(
            "position_std_m", [m for m in fitted if not m["fixed"]]
        ),
        "turn_flagged_tracks": int(sum(sum(bool(f) for f in m["turn_flagged"]) for m in movers)),
        "turn_flagged_pairs_tracks": int(
            sum(sum(bool(f) for f in m.get("turn_flagged_pairs", [])) for m in movers)
        ),
        "turn_tested_tracks": int(
            sum(sum(f is not None for f in m["turn_flagged"]) for m in movers)
        ),
        "coherent_fits": len(focused),
        "coherent_share": (sum(c["coherent"] for c in focused) / len(focused))
        if focused else None,
        "coherent_position_error_median_m": float(
            np.median([c["position_error_m"] for c in focused])
        ) if focused else None,
        "coherent_position_error_max_m": max(
            (c["position_error_m"] for c in focused), default=None
        ),
        "coherent_position_std_median_m": float(np.median(
            [c["position_std_m"] for c in focused if c["position_std_m"] is not None]
        )) if any(c["position_std_m"] is not None for c in focused) else None,
        "coherent_within_2sigma_share": (
            sum(c["mahalanobis"] <= 2.0 for c in measured) / len(measured)
        ) if measured else None,
        "coherent_error_factor_median": float(
            np.median([c["error_factor"] for c in measured])
        ) if measured else None,
        # every mover is uniform: a fixed rate's interval should hold 0
        "ground_rate_tracks": len(rates),
        "ground_rate_fixed": sum(r["fixed"] for r in rates),
        "ground_rate_covers_zero": sum(
            r["interval_deg_s"][0] <= 0.0 <= r["interval_deg_s"][1] for r in rates
        ),
        "seconds": float(sum(d["seconds"] for d in draws)),
    }  # fmt: skip


def markdown(summary: dict) -> str:
    rows = [
        "| aperture | draws | movers tracked | one track | tracks / mover | false tracks "
        "| fixed / family | position error (median, max) | velocity error (median, max) "
        "| std (median) | within 2 sigma (2-D, worst axis) |",
        "|---|---|---|---|---|---|---|---|---|---|---|",
    ]

    def f(x, fmt="{:.2f}"):
        return "-" if x is None else fmt.format(x)

    for ap, s in summary.items():
        rows.append(
            f"| {ap} deg | {s['draws']} | {s['movers_tracked']}/{s['movers']} "
            f"| {f(s['one_track_share'], '{:.0%}')} | {f(s['tracks_per_tracked_mover'])} "
            f"| {s['false_tracks']} | {s['fixed']} / {s['family']} "
            f"| {f(s['fixed_position_error_median_m'])}, {f(s['fixed_position_error_max_m'])} m "
            f"| {f(s['fixed_velocity_error_median_mps'], '{:.3f}')}, "
            f"{f(s['fixed_velocity_error_max_mps'], '{:.3f}')} m/s "
            f"| {f(s['fixed_position_std_median_m'])} m "
            f"| {f(s['within_2sigma_share'], '{:.0%}')}, "
            f"{f(s['within_2sigma_worst_axis_share'], '{:.0%}')} |"
        )
    focused = {ap: s for ap, s in summary.items() if s.get("coherent_fits")}
    if focused:
        rows += [
            "",
            "Focused over each fixed track's pulses (`sarmotion.tracking.coherent`), at the "
            "pass's centre:",
            "",
            "| aperture | fits | coherent | position error (median, max) | std (median) "
            "| within 2 sigma (2-D) | error factor (median) | turn rate fixed, covers 0 |",
            "|---|---|---|---|---|---|---|---|",
        ]
        for ap, s in focused.items():
            rows.append(
                f"| {ap} deg | {s['coherent_fits']} | {f(s['coherent_share'], '{:.0%}')} "
                f"| {f(s['coherent_position_error_median_m'], '{:.4f}')}, "
                f"{f(s['coherent_position_error_max_m'], '{:.4f}')} m "
                f"| {f(s['coherent_position_std_median_m'], '{:.4f}')} m "
                f"| {f(s['coherent_within_2sigma_share'], '{:.0%}')} "
                f"| {f(s['coherent_error_factor_median'], '{:.1f}')} "
                f"| {s.get('ground_rate_fixed', 0)}/{s.get('ground_rate_tracks', 0)}, "
                f"{s.get('ground_rate_covers_zero', 0)}/{s.get('ground_rate_tracks', 0)} |"
            )
    return "\n".join(rows) + "\n"


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--draws", type=int, default=5)
    parser.add_argument("--first", type=int, default=0, help="index of the first draw")
    parser.add_argument("--apertures", type=float, nargs="+", default=[4.0, 10.0, 30.0])
    parser.add_argument("--out", type=Path, default=Path("benchmarks/results"))
    parser.add_argument(
        "--geometric", action="store_true", help="detections made from the geometry (notes)"
    )
    parser.add_argument(
        "--turns", action="store_true", help="the turn tests on uniform and turning movers"
    )
    parser.add_argument("--image-m", type=float, default=IMAGE_M, help="the chain's image side (m)")
    parser.add_argument(
        "--pulses-per-deg", type=int, default=PULSES_PER_DEG, help="the chain's pulse rate"
    )
    parser.add_argument(
        "--frequencies", type=int, default=N_FREQUENCIES, help="the chain's radar frequencies"
    )
    parser.add_argument(
        "--max-crossing-m",
        type=float,
        default=MAX_CROSSING_M,
        help="the farthest a chain's mover travels over the pass (m)",
    )
    parser.add_argument(
        "--band-factor",
        type=float,
        default=BAND_FACTOR,
        help="movers' range speeds beyond this many times the stationary band's edge",
    )
    parser.add_argument(
        "--speckle",
        type=int,
        default=0,
        help="scatterers of distributed clutter over the chain's image (module notes)",
    )
    parser.add_argument(
        "--separation",
        choices=["combined", "rpca", "annihilation"],
        default=None,
        help="the chain's separation method (default: the analysis's)",
    )
    parser.add_argument(
        "--coherent",
        action="store_true",
        help="a mover's looks' fit, then its simulated echo focused over the pass (notes)",
    )
    parser.add_argument(
        "--overlaps", type=float, nargs="+", default=[0.0, 0.5], help="with --turns"
    )
    parser.add_argument(
        "--name", default="wide_aspect", help="stem of the files written (default wide_aspect)"
    )
    parser.add_argument(
        "--join", type=Path, nargs="+", help="join these runs' JSON files into --out/--name"
    )
    args = parser.parse_args(argv)
    args.out.mkdir(parents=True, exist_ok=True)
    draws: dict[str, list[dict]] = {}
    if args.join:
        settings: dict[str, dict] = {}  # each aperture's, from its first file
        for path in args.join:
            doc = json.loads(path.read_text())
            for key, recs in doc["draws"].items():
                draws.setdefault(key, []).extend(recs)
                settings.setdefault(key, doc["settings"])
        summary = {a: summarise(d) for a, d in draws.items()}
        out = {"settings": settings, "summary": summary, "draws": draws}
        (args.out / f"{args.name}.json").write_text(json.dumps(out, indent=1) + "\n")
        (args.out / f"{args.name}.md").write_text(markdown(summary))
        print(markdown(summary))
        return 0
    configure(
        args.image_m, args.pulses_per_deg, args.frequencies, args.max_crossing_m,
        args.band_factor, args.speckle, args.separation,
    )  # fmt: skip
    if args.turns:
        return main_turns(args)
    if args.coherent:
        return main_coherent(args)
    for ap in args.apertures:
        key = f"{ap:g}"
        draws[key] = []
        for k in range(args.first, args.first + args.draws):
            run = run_geometric if args.geometric else run_draw
            rec = run(ap, int(1000 * ap) + k)
            draws[key].append(rec)
            print(json.dumps({k2: v for k2, v in rec.items() if k2 != "movers"}), flush=True)
            for m in rec["movers"]:
                print("   ", {k2: m.get(k2) for k2 in ("speed_mps", "n_tracks", "fixed",
                      "position_error_m", "position_std_m", "velocity_error_mps",
                      "mahalanobis")}, flush=True)  # fmt: skip
            summary = {a: summarise(d) for a, d in draws.items()}
            doc = {
                "settings": {
                    "speed_mps": SPEED_MPS,
                    "pulses_per_deg": PULSES_PER_DEG,
                    "image_m": IMAGE_M,
                    "half_scene_m": HALF_SCENE_M,
                    "max_crossing_m": MAX_CROSSING_M,
                    "frequencies": N_FREQUENCIES,
                    "band_factor": BAND_FACTOR,
                    "speckle": SPECKLE_N,
                    "speckle_amplitude": SPECKLE_AMPLITUDE,
                    "separation": SEPARATION,
                    "n_clutter": N_CLUTTER,
                    "n_movers": N_MOVERS,
                    "snr_db": SNR_DB,
                    "sub_aperture_deg": 1.0,
                    "overlap": 0.0,
                    "two_sigma_2d_expected": float(chi2.cdf(4.0, 2)),
                    "geometric": bool(args.geometric),
                    "geometric_std": GEOMETRIC_STD.tolist() if args.geometric else None,
                },
                "summary": summary,
                "draws": draws,
            }
            (args.out / f"{args.name}.json").write_text(json.dumps(doc, indent=1) + "\n")
            (args.out / f"{args.name}.md").write_text(markdown(summary))
    print(markdown({a: summarise(d) for a, d in draws.items()}))
    return 0


def main_turns(args: argparse.Namespace) -> int:
    """``--turns``: seeded draws per aperture and overlap, both tests (module notes)."""
    draws: dict[str, list[dict]] = {}
    for ap in args.apertures:
        for overlap in args.overlaps:
            key = f"{ap:g} deg, overlap {overlap:g}"
            draws[key] = []
            for k in range(args.first, args.first + args.draws):
                rec = run_turns(ap, int(1000 * ap) + 500 + k, overlap)
                draws[key].append(rec)
                print(key, k, [(t["turn_rate_deg_s"] != 0.0, t["flagged"], t["old_flagged"])
                               for t in rec["tracks"]], flush=True)  # fmt: skip
    summary = {key: summarise_turns(d) for key, d in draws.items()}
    summary["all"] = summarise_turns([r for d in draws.values() for r in d])
    doc = {
        "settings": {
            "false_alarm": TURN_FALSE_ALARM, "turn_rate_deg_s": TURN_RATE_DEG_S,
            "geometric_std": GEOMETRIC_STD.tolist(), "error_factors": TURN_FACTORS.tolist(),
            "pulses_per_deg": GEOMETRIC_PULSES_PER_DEG,
        },
        "summary": summary,
        "draws": draws,
    }  # fmt: skip
    (args.out / f"{args.name}.json").write_text(json.dumps(doc, indent=1) + "\n")
    rows = [
        "| pass | uniform tracks | flagged (looks) | flagged (pairs, before) "
        "| 3 deg/s turns | flagged (looks) | flagged (pairs, before) "
        "| ground rate fixed | interval covers the truth (fixed; all) "
        "| fixed interval width (median) | fixed rate error (max) |",
        "|---|---|---|---|---|---|---|---|---|---|---|",
    ]

    def num(x):
        return "-" if x is None else f"{x:.3f} deg/s"

    for key, v in summary.items():
        rows.append(
            f"| {key} | {v['uniform_tracks']} | {v['uniform_flagged']} "
            f"| {v['uniform_flagged_old']} | {v['turning_tracks']} | {v['turning_flagged']} "
            f"| {v['turning_flagged_old']} | {v['ground_rate_fixed']}/{v['ground_rate_tracks']} "
            f"| {v['ground_rate_fixed_covered']}/{v['ground_rate_fixed']}; "
            f"{v['ground_rate_covered']}/{v['ground_rate_tracks']} "
            f"| {num(v['ground_rate_fixed_width_median_deg_s'])} "
            f"| {num(v['ground_rate_fixed_error_max_deg_s'])} |"
        )
    (args.out / f"{args.name}.md").write_text("\n".join(rows) + "\n")
    print("\n".join(rows))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
