"""The paper's figures, regenerated: every figure is built and shows the paper's finding.

One quick build (reduced grids and sweeps, same code paths) is shared by the module; each
test checks a headline number of one figure against what the paper reports: who beats
whom, which is larger, where a peak sits. Measured values (quick build) are quoted.
"""

from __future__ import annotations

import re

import numpy as np
import pytest

from conftest import gotcha_directory
from sarmotion.paper.figures import CAPTIONS, FIGURE_LABELS, build_figures, figure_filename
from sarmotion.paper.figures.build import SECTIONS

pytestmark = pytest.mark.slow  # ~2 min for the whole quick build (2 cores)

EXPECTED = (
    "fig:setup fig:hyperbola fig:imageComp fig:straightTrace fig:rotScatt fig:dataDecomp "
    "fig:rpcaEx1 fig:rpcaEx2a fig:rpcaEx2b fig:annihilScene1 fig:rpca2mov fig:rotateTrueFilt "
    "fig:filtComp "
    "fig:rotate2stage fig:objfxns fig:rank1 fig:convergeRank fig:eigenvals2 "
    "fig:filter10scatt1ord fig:filter30scatt1ord fig:motEstscatt fig:rpca2movFinalSep "
    "fig:sepImgs"
).split()


@pytest.fixture(scope="module")
def built(tmp_path_factory):
    out = tmp_path_factory.mktemp("paper")
    seen = []
    gdir = gotcha_directory()
    paths = sorted(gdir.glob("data_3dsar_pass1_az00*_HH.mat")) if gdir else None
    records = build_figures(
        out, quick=True, gotcha_paths=paths, progress=lambda lab, i, n: seen.append((lab, i, n))
    )
    return out, {r.label: r for r in records}, seen


def _h(built, label):
    return built[1][label].headline


def test_every_figure_is_built_and_indexed(built):
    out, recs, seen = built
    assert list(recs) == EXPECTED == list(FIGURE_LABELS)
    assert [s[1] for s in seen] == list(range(1, len(EXPECTED) + 1))
    index = (out / "index.html").read_text(encoding="utf-8")
    for lab, r in recs.items():
        assert r.png.name == figure_filename(lab) == lab.replace(":", "_") + ".png"
        assert r.png.exists() and r.png.stat().st_size > 10_000  # a real plot, not a blank
        assert r.npz.exists() and r.npz.stat().st_size > 200
        assert f'src="{r.png.name}"' in index
        assert r.summary and re.search(r"\d", r.summary)  # a measured number
        assert r.headline and r.caption == CAPTIONS[lab]
    # the caption is the paper's, next to the figure
    assert "amounts to two faint streaks" in index
    # sections in the paper's order, every figure in one, a table of contents linking them
    in_sections = [lab for _, _, labels in SECTIONS for lab in labels]
    assert in_sections == EXPECTED
    assert "<nav>" in index and 'href="#fig:sepImgs"' in index and 'id="fig:sepImgs"' in index
    assert index.index('id="sec-1"') < index.index('id="sec-3-2"') < index.index('id="sec-5-3"')
    # the one signal-to-clutter definition is stated
    assert "Signal-to-clutter</b>, in every figure" in index


def test_only_builds_one_figure_and_rejects_unknown_labels(tmp_path):
    recs = build_figures(tmp_path, only="hyperbola", quick=True)
    assert [r.label for r in recs] == ["fig:hyperbola"]
    assert sorted(p.name for p in tmp_path.iterdir()) == [
        "fig_hyperbola.npz",
        "fig_hyperbola.png",
        "index.html",
    ]
    with pytest.raises(ValueError, match="fig:nosuch"):
        build_figures(tmp_path, only="fig:nosuch")


def test_setup_is_drawn_from_the_gotcha_geometry(built):
    h = _h(built, "fig:setup")
    if gotcha_directory() is not None:
        assert h["from_data"] == 1.0
        assert h["n_pulses"] > 400  # four one-degree files
    # GOTCHA: 4 degrees of a circle about 7.1 km in radius at 7.3 km altitude: L ~ 10 km,
    # elevation ~ 45 degrees, a ~ 7.1 km x 4 pi / 180 ~ 0.49 km. Measured 10.16 km,
    # 45.7 degrees, 494 m.
    assert 9.5e3 < h["range_to_reference_m"] < 11e3
    assert 40.0 < h["elevation_deg"] < 50.0
    assert h["aperture_deg"] == pytest.approx(4.0, abs=0.1)
    a_expected = h["ground_range_m"] * np.radians(h["aperture_deg"])
    assert h["aperture_length_m"] == pytest.approx(a_expected, rel=0.02)


def test_range_compression_and_alignment_remove_the_slow_time_dependence(built):
    h = _h(built, "fig:hyperbola")
    # Sub-sample peaks: measured 14.0 ns -> 1.34 ns (one sample is 1.6 ns).
    assert h["migration_pulse_compressed_ns"] > 10.0
    assert h["migration_range_compressed_ns"] < 2.0
    h = _h(built, "fig:straightTrace")
    # The range-compressed trace still bends by a fraction of a sample (measured 0.80 ns,
    # the travel-time spread 0.805 ns); after T_+ it is straight to rounding.
    assert 0.3 < h["migration_before_ns"] < 1.6
    assert h["migration_after_ns"] < 1e-6
    assert h["aligned_column_rel_std"] < 1e-8


def test_movers_are_faint_streaks_in_the_image(built):
    # Measured -31 dB re the brightest stationary target.
    assert _h(built, "fig:imageComp")["mover_streak_db"] < -20.0


def test_q_annihilates_the_stationary_trace_and_keeps_the_mover(built):
    h = _h(built, "fig:rotScatt")
    assert h["stationary_energy_after_Q_db"] < -200.0  # exact location: exact zero
    assert h["mover_energy_after_Q_db"] > -10.0


def test_moving_traces_have_high_rank(built):
    h = _h(built, "fig:dataDecomp")
    assert h["rank_S"] > 2 * h["rank_L"]  # measured 75 vs 24
    h = _h(built, "fig:rpcaEx2a")
    assert h["rank_L_example2"] > 5 * h["rank_L_example1"]  # measured 34 vs 3


@pytest.mark.parametrize("label", ["fig:rpcaEx1", "fig:rpcaEx2b"])
def test_windowed_rpca_beats_whole_matrix(built, label):
    h = _h(built, label)
    # Measured: Example 1 0.24 vs 1.37, Example 2 0.79 vs 4.62.
    assert h["rel_error_S_windowed"] < 0.5 * h["rel_error_S_whole"]
    assert h["rel_error_L_windowed"] < h["rel_error_L_whole"]
    assert h["rel_error_S_windowed"] < 1.0


def test_annihilation_keeps_every_pulse_of_the_aperture(built):
    h = _h(built, "fig:annihilScene1")
    # ~100 filters from the image on 117 pulses: every pulse keeps the movers within 40 dB
    # of their largest per-pulse energy and nowhere is more than -40 dB of stationary
    # energy left (quick grid; measured -26.4 dB / -58.8 dB on 0.5 m, -36.5 / -57.5 dB on
    # the full 0.25 m grid).
    assert h["n_filters"] > 58
    assert h["pulses_movers_within_40db"] == 1.0
    assert h["max_pulse_stationary_db"] <= -40.0


def test_rpca_keeps_more_mover_trace_than_annihilation(built):
    ann = _h(built, "fig:annihilScene1")
    rp = _h(built, "fig:rpca2mov")
    # Measured 0.65 (annihilation, filters from the image) vs 0.81 (windowed RPCA).
    assert rp["mover_trace_coverage"] > ann["mover_trace_coverage"] + 0.1
    # Even with the exact stationary locations (measured 0.74) the filter cuts the movers.
    assert rp["mover_trace_coverage"] > ann["mover_trace_coverage_exact_locations"]
    # ... while the filter leaves less clutter (one definition; measured 65 dB vs 5.0 dB):
    # the paper's trade-off.
    assert ann["signal_to_clutter_db"] > rp["signal_to_clutter_db"] + 20.0


def test_aligned_mover_traces_are_vertical(built):
    h = _h(built, "fig:rotateTrueFilt")
    for k in (1, 2):
        assert h[f"mover{k}_migration_before_ns"] > 50.0
        assert h[f"mover{k}_migration_after_ns"] < 2.0


def test_g_peaks_at_zero_on_all_traces_and_at_the_range_speeds_on_moving_ones(built):
    h = _h(built, "fig:filtComp")
    step = 0.25  # quick grid (m/s)
    assert abs(h["peak_all_mps"]) <= step
    for k in (1, 2):
        assert abs(h[f"peak_moving_{k}_mps"] - h[f"true_range_speed_{k}_mps"]) <= step


def test_g_perp_minima_at_the_true_cross_range_speeds(built):
    h = _h(built, "fig:objfxns")
    for k in (1, 2):  # measured 20.0 vs 19.8 and 11.5 vs 11.4 on the 0.5 m/s grid
        assert abs(h[f"g_perp_min_{k}_mps"] - h[f"true_u_perp_{k}_mps"]) < 1.5
        assert abs(h[f"estimate_{k}_mps"] - h[f"true_u_perp_{k}_mps"]) < 1.5


def test_cross_range_correction_straightens_the_trace(built):
    assert _h(built, "fig:rotate2stage")["g_perp_ratio"] < 0.1


def test_rank_grows_linearly_and_movers_have_much_higher_rank(built):
    h = _h(built, "fig:rank1")
    # Measured slopes 0.36 /m (Szegő 0.34) and 12.3 per m/s (Szegő 12.3).
    assert h["r2_offset"] > 0.9 and h["r2_speed"] > 0.98
    assert h["slope_offset_per_m"] == pytest.approx(h["slope_offset_szego_per_m"], rel=0.25)
    assert h["slope_speed_per_mps"] == pytest.approx(h["slope_speed_szego_per_mps"], rel=0.1)
    assert h["rank_mover_max_speed"] > 10 * h["rank_stationary_10m_1deg"]  # 63 vs 4


def test_rank_fraction_converges_to_szego(built):
    h = _h(built, "fig:convergeRank")
    # Measured 1.89 at n+1 = 117 and 1.07 at n+1 = 936 (8 degrees, included in quick).
    assert h["ratio_smallest_n"] > 1.5
    assert abs(h["ratio_largest_n"] - 1.0) < 0.10


def test_b_beta_in_the_papers_convention(built):
    h = _h(built, "fig:eigenvals2")
    assert h["B_beta_flat_left"] == pytest.approx(41.47, rel=2e-3)  # c = 3e8 in the paper
    assert h["B_beta_3d_left"] == pytest.approx(28.93, rel=2e-3)
    assert h["B_beta_flat_right"] < 2.0  # the traces overlap in fast time


def test_exact_filters_annihilate_the_stationary_traces(built):
    for name in ("fig:filter10scatt1ord", "fig:filter30scatt1ord"):
        h = _h(built, name)
        # every shown pulse with a complete stencil: measured 135 and 174 dB
        assert h["signal_to_clutter_db"] > 100.0
        # on the scene's own pulses the incomplete end stencils leave clutter (38.6, 61.1 dB)
        assert h["signal_to_clutter_finite_aperture_db"] < h["signal_to_clutter_db"]


def test_fewer_stationary_targets_give_a_better_trajectory(built):
    h = _h(built, "fig:motEstscatt")
    # Complete stencils (the filter, not the end of the aperture): measured max 0.015 m
    # (ten) vs 0.023 m (thirty), rms 0.008 vs 0.013 m: the residues of more filters add up.
    assert h["max_error_filter10_m"] < h["max_error_filter30_m"]
    assert h["rms_error_filter10_m"] < h["rms_error_filter30_m"]
    assert h["max_error_filter30_m"] < 0.24  # below the range resolution c/2B


def test_final_separation_finds_both_movers(built):
    out, recs, _ = built
    h = _h(built, "fig:rpca2movFinalSep")
    assert h["n_movers"] == 2
    # The paper's T_+^{u,rho} + RPCA separates the two movers' traces: each is closer to
    # its own true trace than to nothing (measured 0.47 and 0.67), with positive
    # signal-to-clutter (6.5 and 3.4 dB); sarmotion's extract_mover does better (0.27,
    # 0.31).
    for k in (1, 2):
        assert h[f"paper_mover{k}_rel_error"] < 0.9
        assert h[f"paper_mover{k}_signal_to_clutter_db"] > 0.0
        assert h[f"mover{k}_rel_error"] < h[f"paper_mover{k}_rel_error"]
    index = (out / "index.html").read_text(encoding="utf-8")
    assert "T_+^{u,ρ} + RPCA" in index and "extract_mover" in index
    assert f"{h['paper_mover1_rel_error']:.2f}" in index


def test_separated_images_focus_at_the_true_positions(built):
    h = _h(built, "fig:sepImgs")
    # the paper's lambda L / a (2.5 m at one degree) is twice the cell used here
    assert h["paper_cross_range_resolution_m"] == pytest.approx(2 * h["cross_range_cell_m"])
    assert h["paper_cross_range_resolution_m"] == pytest.approx(2.5, rel=0.05)
    cell = max(h["range_cell_m"], h["cross_range_cell_m"])
    # Measured (full build): 19 of 20 within a cell, median 0.11 m; the miss is the pair
    # (-17.79, 22.43) / (-16.97, 23.50) m, 1.35 m apart, merged into one peak.
    assert h["stationary_within_cell"] >= h["n_stationary"] - 1
    assert h["stationary_median_peak_error_m"] < 0.5 * cell
    assert abs(h["mover1_peak_range_error_m"]) < h["range_cell_m"]
    assert abs(h["mover1_peak_cross_range_error_m"]) < h["cross_range_cell_m"]
    # Mover 2: in range within a cell, but displaced in cross range (measured 6.05 m,
    # ~5 cells; the paper: "slightly displaced in cross-range due to the error in its
    # velocity estimation"). The displacement is the range-speed/cross-range degeneracy
    # documented in sarmotion.motion; asserted as it is, so a fix shows up here.
    assert abs(h["mover2_peak_range_error_m"]) < h["range_cell_m"]
    assert abs(h["mover2_peak_cross_range_error_m"]) > h["cross_range_cell_m"]


def test_every_figure_reads_at_8_pt_or_more_in_the_index(built):
    """Each figure's smallest text (legends, tick and axis labels) as the index shows it:
    ``text_pt x dpi / 96`` CSS pt at natural size, scaled by the index's column over the
    PNG's width when wider (a 1400-px window)."""
    from PIL import Image

    from sarmotion.paper.figures.build import _STYLE, INDEX_COLUMN_PX

    # the column the constant stands for: the navigation's and main's widths
    assert "flex:0 0 17em" in _STYLE and "padding:1em 2.5em" in _STYLE
    _, recs, _ = built
    shown = {}
    for lab, r in recs.items():
        png = Image.open(r.png)
        dpi = float(png.info["dpi"][0])
        scale = min(1.0, INDEX_COLUMN_PX / png.width)
        shown[lab] = r.text_pt * dpi / 96.0 * scale
    assert min(shown.values()) >= 8.0, {k: round(v, 2) for k, v in shown.items() if v < 8.0}
    # the legends are set at 8 pt: the least text of at least the figures with legends
    assert sum(r.text_pt == 8.0 for r in recs.values()) >= 5
