"""Shared fixtures: small seeded scenes and the location of the GOTCHA data set.

The test run writes nothing into the source tree: numba's on-disk cache (``cache=True``
kernels) and Python's bytecode (where it is written) go under one directory in the
system's temporary directory, set here before any test imports sarmotion (and so
numba) and passed on, in the environment, to the commands the tests start. A ``NUMBA_CACHE_DIR`` or
``PYTHONPYCACHEPREFIX`` already set is kept. The directory persists between runs, so the
kernels compile once, not once per run; numba keys its entries by the source file's full
path and time stamp, so checkouts side by side do not share them.
"""

from __future__ import annotations

import os
import sys
import tempfile
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]

_CACHE = Path(tempfile.gettempdir()) / "sarmotion-test-cache"
os.environ.setdefault("NUMBA_CACHE_DIR", str(_CACHE / "numba"))
if not sys.flags.dont_write_bytecode:
    # where no bytecode is written (PYTHONDONTWRITEBYTECODE) nothing reaches the tree, and
    # a prefix would only hide the installed packages' bytecode from the commands the
    # tests start: every module, numpy's and Dask's too, compiled at each start
    os.environ.setdefault("PYTHONPYCACHEPREFIX", str(_CACHE / "pycache"))
    if sys.pycache_prefix is None:
        sys.pycache_prefix = os.environ["PYTHONPYCACHEPREFIX"]


# The test tiers. ``python -m pytest`` runs the fast tier (pyproject.toml's addopts
# deselect ``slow``): every module of the package is exercised, in at most 5 minutes on 2
# cores. ``python -m pytest -m slow`` runs the rest; CI (.ci/run) runs both. A test is slow
# when its file is in SLOW_FILES, its node id (without parameters) in SLOW_TESTS, or it is
# marked ``@pytest.mark.slow`` in its file. Kept here, in one place, so that the tiers can be
# read and changed without touching the test files.

#: Files whose every test is in the slow tier (another file exercises the same modules fast).
SLOW_FILES: frozenset[str] = frozenset()

#: Single tests (or every parameter of one) in the slow tier: ``file.py::test_name``.
SLOW_TESTS: frozenset[str] = frozenset(
    [
        # Tests that took over 1.5 CPU-seconds (a parameter of them, or their module's
        # fixture), measured one by one: the fast tier's 5 minutes over its ~1200 tests
        # leave 0.25 s a test on average, and these few hold most of the time.
        "test_acceleration.py::test_acceleration_towards_the_radar_is_recovered",
        "test_acceleration.py::test_held_cross_range_offset_is_within_its_spread",
        "test_acceleration.py::test_noise_free_acceleration_is_recovered",
        "test_analysis.py::test_extract_mover_separates_two_crossing_movers",
        "test_analyze_device.py::test_every_image_goes_to_the_device",
        "test_api.py::test_report_legends_read_at_8_pt_as_the_page_shows_them",
        "test_api.py::test_repr_is_a_line_with_the_counts_and_the_time",
        "test_api.py::test_save_report_writes_the_report_alone",
        "test_api.py::test_save_writes_what_analyze_writes_and_refuses_to_overwrite",
        "test_autofocus.py::test_final_fit_drops_lines_whose_window_holds_more_than_its_point",
        "test_backprojection_accuracy.py::test_gotcha_image_reaches_its_accuracy",
        "test_backprojection_accuracy.py::test_motion_compensated_image_reaches_the_accuracy",
        "test_backprojection_accuracy.py::test_simulated_points_reach_the_accuracy",
        "test_cli.py::test_image_method_ffbp_against_exact",
        "test_cli.py::test_image_of_a_scene_focuses_the_target",
        "test_cli.py::test_image_on_an_explicit_grid",
        "test_cli.py::test_image_real_gotcha",
        "test_cli.py::test_inject_and_image_compensated",
        "test_cli.py::test_paper_builds_a_figure_and_rejects_unknown_labels",
        "test_cli.py::test_paper_setup_reads_the_gotcha_directory",
        "test_cli.py::test_separate_writes_traces_figures_and_quality",
        "test_cli_autofocus.py::test_bare_autofocus_flag_means_gotcha",
        "test_cli_autofocus.py::test_convert_with_pga_writes_corrected_traces",
        "test_cli_autofocus.py::test_image_with_pga_writes_the_phase_error",
        "test_cli_cphd.py::test_convert_back_from_cphd_with_a_vector_range",
        "test_cli_cphd.py::test_convert_to_cphd_and_image_it",
        "test_cli_hardening.py::test_directory_where_an_output_file_goes",
        "test_cli_hardening.py::test_existing_outputs_need_force",
        "test_cli_hardening.py::test_failed_move_into_out_is_undone",
        "test_cli_hardening.py::test_hdf5_reading_that_does_not_finish_is_refused",
        "test_cli_hardening.py::test_quiet_after_the_command",
        "test_cli_help.py::test_inject_amplitude_in_db_is_relative_to_a_typical_pulses_strongest_echo",
        "test_cli_help.py::test_track_takes_the_analysis_method_and_false_alarm_rate_and_says_why_no_track",
        "test_cli_small.py::test_a_concurrent_analysis_into_one_new_out_is_refused_before_reading",
        "test_cli_small.py::test_a_directory_input_is_its_gotcha_files",
        "test_cli_small.py::test_paper_finds_the_gotcha_data_beside_the_clone",
        "test_coherent_detection.py::test_no_mover_on_a_real_degree",
        "test_collection.py::test_a_patch_rejects_stationary_echoes_outside_its_band",
        "test_collection.py::test_patch_traces_are_the_data_compressed_to_the_patch_centre",
        "test_collection.py::test_plan_tiles_the_region_and_sizes_the_margins_for_every_mover",
        "test_collection_cphd.py::test_analysis_of_the_file_finds_each_mover_on_its_family",
        "test_collection_cphd.py::test_ctrl_c_stops_every_worker",
        "test_collection_dead_zone.py::test_lone_mover_where_patches_meet_is_found_once",
        "test_collection_doppler.py::test_the_mover_is_found_where_its_doppler_places_it",
        "test_collection_doppler.py::test_the_stationary_list_is_the_scene_not_noise_nor_the_movers_image",
        "test_collection_resample.py::test_a_mover_aliased_in_the_data_keeps_whole_pulses",
        "test_collection_resample.py::test_a_patch_keeps_the_pulses_its_band_needs_and_its_movers_at_the_speed_bound",
        "test_collection_run.py::test_a_scheduler_given_by_its_address_gives_the_same_answers",
        "test_collection_run.py::test_command_line_collection_outputs",
        "test_collection_run.py::test_the_collection_finds_the_movers_the_whole_trace_analysis_finds",
        "test_collection_run.py::test_distributed_process_workers_give_the_same_answers",
        "test_collection_run.py::test_patches_in_process_give_the_same_answers_and_mosaic",
        "test_collection_run.py::test_two_patches_find_the_border_mover_once_and_every_stationary_point",
        "test_defocus.py::test_analysis_finds_a_slow_mover_beside_a_stationary_point",
        "test_defocus.py::test_analysis_finds_the_mover_on_its_family",
        "test_defocus.py::test_echo_residue_is_what_a_model_leaves_of_its_own_echo",
        "test_defocus.py::test_skipping_the_joint_fit_keeps_every_verdict",
        "test_detector_null.py::test_null_tail_holds_on_the_real_degrees",
        "test_documents_schema.py::test_every_written_json_document_validates",
        "test_documents_schema.py::test_the_range_speed_span_holds_the_truth_the_standard_error_does_not",
        "test_fast_imaging.py::test_avx2_window_read_matches_the_gathers",
        "test_fast_imaging.py::test_ffbp_on_gotcha_in_strips",
        "test_fast_imaging.py::test_near_range_geometry_uses_the_float64_kernel",
        "test_fast_imaging.py::test_trace_table_cache",
        "test_fast_imaging.py::test_window_edge_mask_skips_only_blocks_without_edges",
        "test_ffbp_accuracy.py::test_ffbp_of_gotcha_reaches_its_accuracy",
        "test_ffbp_accuracy.py::test_ffbp_of_simulated_points_reaches_its_accuracy",
        "test_ffbp_accuracy.py::test_ffbp_reaches_its_accuracy_at_every_planned_oversampling",
        "test_ffbp_oblique.py::test_ffbp_at_any_look_direction",
        "test_ffbp_oblique.py::test_ffbp_on_gotcha_turned_to_an_oblique_look",
        "test_ffbp_oblique.py::test_window_ends_are_computed_exactly",
        "test_fit_lobes.py::test_found_movers_are_on_their_lobe",
        "test_fuzz_scene.py::test_mutated_scene_files_exit_0_or_2_in_one_line_leaving_nothing",
        "test_imaging_threads.py::test_cache_stress_without_imaging",
        "test_imaging_threads.py::test_concurrent_backprojection_with_evictions",
        "test_input_limits.py::test_mat_data_that_inflates_beyond_the_limit_is_refused",
        "test_input_limits.py::test_mat_variables_other_than_data_are_not_inflated",
        "test_input_limits.py::test_never_written_huge_native_dataset_is_refused",
        "test_input_limits.py::test_plausible_track_with_huge_compressed_data_is_refused_by_image",
        "test_input_limits.py::test_scene_with_10_to_8_pulses_is_refused",
        "test_input_limits.py::test_scene_work_is_limited",
        "test_input_limits.py::test_sparse_cphd_declaring_200000_vectors_is_refused",
        "test_io_cphd.py::test_cphdcheck_command_passes_a_written_file",
        "test_io_gotcha.py::test_calibration_reflectors_focus",
        "test_io_native.py::test_schema_kind_and_version_are_checked",
        "test_layering.py::test_an_upward_import_is_found",
        "test_movers_detection.py::test_bound_is_reached_by_the_fit_in_white_noise",
        "test_movers_detection.py::test_two_movers_of_one_range_speed_at_two_ranges_are_both_found",
        "test_movers_detection.py::test_two_movers_with_one_range_speed_are_both_found",
        "test_outputs.py::test_a_concurrent_run_is_refused_at_once_naming_the_holder",
        "test_outputs.py::test_force_leaves_no_stale_output_of_the_same_command",
        "test_outputs.py::test_sigkill_at_any_step_leaves_the_old_output_or_the_new",
        "test_outputs.py::test_staging_folders_of_dead_runs_are_removed",
        "test_outputs.py::test_two_runs_into_one_new_out_at_once",
        "test_progress.py::test_image_on_a_terminal_says_its_plan_then_shows_a_bar",
        "test_progress.py::test_pga_says_what_it_found",
        "test_progress.py::test_quiet_leaves_only_the_summary",
        "test_progress.py::test_a_long_command_says_its_plan_and_shows_a_bar_within_5_s",
        "test_progress.py::test_quiet_long_commands_print_only_their_summary",
        "test_quality.py::test_hann_weighting_lowers_the_sidelobes",
        "test_rank.py::test_baseband_rank_matches_baseband_szego_at_large_n",
        "test_rank.py::test_predict_window_bounds_the_stationary_rank_in_each_window",
        "test_rank.py::test_rank_fraction_converges_to_szego",
        "test_rank.py::test_rank_grows_linearly_with_cross_range_offset",
        "test_rank.py::test_two_stationary_targets_rank_follows_the_toeplitz_part",
        "test_report_html.py::test_a_simulated_scene_without_movers_says_so_instead_of_empty_tables",
        "test_report_html.py::test_a_wide_figure_is_shrunk_until_its_legends_read_at_8_pt_in_the_column",
        "test_report_html.py::test_estimates_and_true_targets_are_named_apart",
        "test_report_html.py::test_mover_images_keep_legible_legends_for_any_number_of_movers",
        "test_report_html.py::test_report_gives_the_aperture_in_degrees",
        "test_report_html.py::test_report_without_truth_has_no_truth_captions_and_no_empty_mover_panel",
        "test_report_html.py::test_trajectory_error_axis_is_linear_and_trace_ticks_legible",
        "test_report_style.py::test_analysis_track_and_collection_reports_share_one_page_style",
        "test_report_style.py::test_collection_mosaic_shows_the_look_direction",
        "test_report_style.py::test_image_command_draws_the_look_direction",
        "test_report_style.py::test_image_figures_of_the_analysis_report_show_the_look_direction",
        "test_results_known.py::test_candidates_beyond_max_movers_are_counted_listed_and_said",
        "test_results_known.py::test_console_gives_the_range_with_its_error_and_the_cross_range_as_unknown",
        "test_results_known.py::test_images_figure_draws_the_family_not_a_circle",
        "test_results_known.py::test_max_movers_0_lists_every_detection_and_never_says_none_passed",
        "test_results_known.py::test_mover_and_trajectory_figures_draw_the_family_across_the_scene",
        "test_results_known.py::test_real_outputs_validate_against_the_schema",
        "test_results_known.py::test_results_say_cross_range_unknown_and_give_the_range_the_data_fix",
        "test_rpca_stacked.py::test_gram_threshold_is_singular_value_thresholding",
        "test_rpca_stacked.py::test_stacked_ialm_matches_the_textbook_loop_and_handles_edges",
        "test_rpca_stacked.py::test_stacked_windows_on_a_gotcha_degree_are_the_plain_ialm",
        "test_simulate.py::test_simulate_refuses_a_scene_that_aliases_and_lenient_writes_it",
        "test_track.py::test_a_road_that_fits_no_detection_says_why",
        "test_truth_matching.py::test_an_aliased_mover_is_a_false_mover_plus_a_missed_one",
        "test_wide_aspect.py::test_one_mover_cut_in_pieces_is_one_track_two_movers_are_two",
    ]
) | frozenset(
    # The CUDA kernels under numba's CUDA simulator (the module's ``simulated`` fixture: every
    # case interpreted in Python in a child process); the host-side tests of the same file,
    # the table, the row bands, the one-line errors without a GPU, stay fast.
    f"test_cuda_sim.py::{name}"
    for name in (
        "test_every_pixel_within_the_stated_bound",
        "test_signal_to_error_against_the_exact_sum",
        "test_the_cases_cover_every_pixels_per_thread",
        "test_command_line_device_cuda",
        "test_zero_outside_the_fast_time_window_like_the_cpu",
        "test_ffbp_on_the_gpu_reaches_its_accuracy",
        "test_row_bands_give_the_image_of_one_launch",
        "test_an_overflowing_gpu_image_is_refused",
        "test_table_built_on_the_device_within_its_bound",
        "test_ffbp_cases_cover_the_window_ends",
    )
)


@pytest.hookimpl(tryfirst=True)
def pytest_collection_modifyitems(config: pytest.Config, items: list[pytest.Item]) -> None:
    """Mark the tests of SLOW_FILES and SLOW_TESTS ``slow`` before ``-m`` selects."""
    for item in items:
        name = item.nodeid.split("::", 1)[0].rsplit("/", 1)[-1]
        test = f"{name}::{item.nodeid.split('::', 1)[-1].split('[', 1)[0]}"
        if name in SLOW_FILES or test in SLOW_TESTS:
            item.add_marker(pytest.mark.slow)


def gotcha_directory() -> Path | None:
    """The GOTCHA data directory: $SARMOTION_GOTCHA_DIR, else ../shared/data/gotcha."""
    env = os.environ.get("SARMOTION_GOTCHA_DIR")
    candidates = [Path(env)] if env else []
    candidates.append(ROOT.parent / "shared" / "data" / "gotcha")
    for c in candidates:
        if c.is_dir() and any(c.glob("data_3dsar_pass1_az00*_HH.mat")):
            return c
    return None


@pytest.fixture(scope="session")
def gotcha_dir() -> Path:
    """Directory holding the GOTCHA pass-1 HH .mat files.

    Skips with a reason when absent, unless SARMOTION_REQUIRE_GOTCHA=1 (set by CI), in
    which case the test fails.
    """
    d = gotcha_directory()
    if d is None:
        msg = (
            "GOTCHA data not found: set SARMOTION_GOTCHA_DIR or place the files in "
            f"{ROOT.parent / 'shared' / 'data' / 'gotcha'}"
        )
        if os.environ.get("SARMOTION_REQUIRE_GOTCHA") == "1":
            pytest.fail(msg)
        pytest.skip(msg)
    return d


@pytest.fixture(scope="session")
def gotcha_files(gotcha_dir: Path) -> list[Path]:
    """The four 1-degree GOTCHA files, in azimuth order."""
    return sorted(gotcha_dir.glob("data_3dsar_pass1_az00*_HH.mat"))
