"""Point-target quality: IRW, PSLR and ISLR of a simulated point against sinc theory."""

from __future__ import annotations

import numpy as np
import pytest

from sarmotion.imaging.quality import (
    SINC_IRW_FACTOR,
    SINC_PSLR_DB,
    cut_quality,
    point_quality,
    sinc_islr_db,
)
from sarmotion.simulation import PointTarget, Scene, simulate


def point_scene(aperture_deg, position=(3.0, -2.0)):
    return Scene(
        name="point",
        targets=(PointTarget(position_m=position),),
        reference_point_m=(0.0, 0.0, 0.0),
        trajectory_spec={"kind": "circular", "aperture_deg": aperture_deg},
    )


def test_sinc_constants_from_their_definitions():
    x = np.linspace(-5.0, 5.0, 200_001)
    q = cut_quality(x, np.sinc(x))
    assert q.irw_m == pytest.approx(SINC_IRW_FACTOR, rel=1e-4)
    assert q.pslr_db == pytest.approx(SINC_PSLR_DB, abs=1e-3)
    # ISLR over |x| <= 5 by sums on a fine grid against the Si closed form.
    assert q.islr_db == pytest.approx(sinc_islr_db(5.0), abs=1e-3)
    # Far tails: sidelobe energy -> 1 - 2 Si(2 pi) / pi.
    assert sinc_islr_db(1e6) == pytest.approx(-9.68, abs=0.01)


@pytest.mark.parametrize("aperture_deg", [1.0, 4.0])
def test_simulated_point_matches_rect_theory(aperture_deg):
    # A rect range spectrum and pulses evenly spaced in angle: both cuts are sincs, up to
    # the Dirichlet kernel of the discrete spectrum and the keystone of the polar support.
    tr = simulate(point_scene(aperture_deg)).traces
    q = point_quality(tr, (3.1, -2.1))
    assert np.hypot(*(q.position_m[:2] - (3.0, -2.0))) < 1e-3
    for meas, theory in ((q.range, q.range_theory), (q.cross_range, q.cross_range_theory)):
        assert meas.irw_m == pytest.approx(theory.irw_m, rel=0.02)
        assert meas.pslr_db == pytest.approx(SINC_PSLR_DB, abs=0.3)
        assert meas.islr_db == pytest.approx(theory.islr_db, abs=0.5)
    d = q.to_dict()
    assert d["range"]["irw_theory_m"] == pytest.approx(q.range_theory.irw_m)


def test_hann_weighting_lowers_the_sidelobes():
    # The measurement sees a window: a Hann-weighted range spectrum has -31.5 dB
    # sidelobes and a 1.44 cell (vs 0.886) 3 dB width.
    x = np.linspace(-10, 10, 40_001)
    f = np.linspace(-0.5, 0.5, 2001)
    w = 0.5 + 0.5 * np.cos(2 * np.pi * f)
    prof = np.abs(np.exp(2j * np.pi * np.outer(x, f)) @ w)
    q = cut_quality(x, prof)
    assert q.pslr_db == pytest.approx(-31.5, abs=0.1)
    assert q.irw_m == pytest.approx(1.44, rel=0.01)


def test_cut_without_nulls_is_refused():
    x = np.linspace(-1, 1, 101)
    with pytest.raises(ValueError, match="no null"):
        cut_quality(x, np.exp(-(x**2)))


def test_gaussian_pulse_range_width():
    # Radar(pulse="gaussian"): |p| = exp(-B^2 t^2 / 2), IRW 2 sqrt(ln 2) cells, no sidelobes.
    from sarmotion.core import Radar

    scene = point_scene(1.0)
    scene = Scene(
        name="g", targets=scene.targets, reference_point_m=(0.0, 0.0, 0.0),
        trajectory_spec=scene.trajectory_spec, radar=Radar(pulse="gaussian"),
    )  # fmt: skip
    q = point_quality(simulate(scene).traces, (3.0, -2.0), n_cells=6)
    assert q.range.irw_m == pytest.approx(q.range_theory.irw_m, rel=0.02)
    assert q.to_dict()["range"]["pslr_theory_db"] is None
