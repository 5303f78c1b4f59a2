"""Shared test fixtures: repository paths, the ../shared data folder, a GUI server."""

from __future__ import annotations

import os
from pathlib import Path

import pytest

os.environ.setdefault("VTK_DEFAULT_OPENGL_WINDOW", "vtkEGLRenderWindow")

REPO = Path(__file__).resolve().parents[1]
SHARED_DATA = REPO.parent / "shared" / "data"


@pytest.fixture
def shared_data():
    """Path of ../shared/data; skips the test where it is absent (a user's fresh clone)."""
    if not SHARED_DATA.is_dir():
        pytest.skip(f"{SHARED_DATA} is absent (only CI and developers have ../shared)")
    return SHARED_DATA


@pytest.fixture
def gui_server(tmp_path):
    """Start the GUI on a fresh project; yield its URL and its output lines."""
    from camcmm.errors import CamcmmError
    from camcmm.gui.process import GuiProcess

    try:
        server = GuiProcess(tmp_path / "proj")
    except CamcmmError as exc:
        pytest.fail(str(exc))
    yield server.url, server.log
    server.stop()


_gui_names = __import__("itertools").count()


@pytest.fixture
def gui_app(tmp_path):
    """Build GUI servers in-process (no browser, no port): ``make(project_dir=None, **build_kw)``
    returns ``(server, session)``; the page objects are ``server.pages[key]``. Every server
    made is closed after the test."""
    from camcmm.gui.app import build, close

    made = []

    def make(project_dir=None, **kw):
        server, session = build(f"test-gui-{os.getpid()}-{next(_gui_names)}", project_dir or tmp_path / "proj", **kw)
        server.state.ready()
        made.append(server)
        return server, session

    yield make
    for server in made:
        close(server)


def run_camcmm(*args, ok=True, timeout=300, **kw):
    """``python -m camcmm ARGS`` in a subprocess; asserts exit 0 when ``ok``; returns the
    CompletedProcess (text). Import it from conftest in a test module."""
    import subprocess
    import sys

    proc = subprocess.run(
        [sys.executable, "-m", "camcmm", *map(str, args)], capture_output=True, text=True, timeout=timeout, **kw
    )
    if ok:
        assert proc.returncode == 0, proc.stderr
    return proc


# -- marks by rule ---------------------------------------------------------------------------------
# `pytest -m "not slow"` is the quick run (under two minutes on the 2-core reference machine).
# The browser tests are marked here by their file name; the other slow ones by their node id below,
# so that the list lives in one place. Measured on 2026-11-25 on the 2-core machine shared with seven
# other runs: first every test whose call took >= 8 s under load 5-12 (with the tests sharing a module
# fixture that takes that long), then, in the remaining quick run under load 2-8, every test that took
# >= 1 s of wall or CPU time (the whole bad-input matrix of test_bad_inputs.py: its worker pool alone
# takes 15 s). A parametrized test is listed by its full id, or by its name for every parameter.
SLOW_TESTS: frozenset[str] = frozenset(
    {
        "tests/test_bad_inputs.py::test_bad_input",
        "tests/test_bad_inputs.py::test_the_harness_catches_each_misbehaviour[alloc-used 1.]",
        "tests/test_bad_inputs.py::test_the_harness_catches_each_misbehaviour[hang-hang: no answer in 3 s]",
        "tests/test_calibration_camera.py::test_bad_inputs",
        "tests/test_calibration_camera.py::test_calibration_recovers_the_rendering_camera",
        "tests/test_calibration_camera.py::test_detection_matches_exact_projection[acircles:4x11:10-350]",
        "tests/test_calibration_camera.py::test_detection_matches_exact_projection[charuco:8x6:20:15-450]",
        "tests/test_calibration_camera.py::test_detection_matches_exact_projection[chessboard:9x6:20-450]",
        "tests/test_calibration_camera.py::test_detection_matches_exact_projection[circles:7x6:20-450]",
        "tests/test_calibration_cli.py::test_bad_input",
        "tests/test_calibration_cli.py::test_calibrate_camera_json_and_file",
        "tests/test_calibration_cli.py::test_calibrate_stereo_json",
        "tests/test_calibration_cli.py::test_run_through_the_host",
        "tests/test_calibration_cli.py::test_scale_and_gauge_block",
        "tests/test_calibration_gui.py::test_bad_input_gives_one_line_and_the_page_keeps_working",
        "tests/test_calibration_gui.py::test_camera_shows_the_plugins_numbers_corners_and_heat_map",
        "tests/test_calibration_gui.py::test_figures_and_pngs",
        "tests/test_calibration_gui.py::test_images_from_an_upload_and_from_the_project_items",
        "tests/test_calibration_gui.py::test_stereo_pair_pose_epipolar_and_rectified_pair",
        "tests/test_calibration_gui.py::test_stored_downloaded_used_by_a_system_and_restored",
        "tests/test_calibration_gui.py::test_worker_run_with_progress",
        "tests/test_calibration_real.py::test_bouguet_example",
        "tests/test_calibration_real.py::test_opencv_left_default_pipeline_and_heat_map",
        "tests/test_calibration_triangulation.py::test_covariance_against_monte_carlo",
        "tests/test_calibration_uncertainty.py::test_projection_uncertainty_monte_carlo",
        "tests/test_calibration_uncertainty.py::test_stereo_uncertainty_monte_carlo",
        "tests/test_calibration_warnings.py::test_bouguet_example_has_no_warning",
        "tests/test_calibration_warnings.py::test_calibration_page_shows_the_warnings",
        "tests/test_calibration_warnings.py::test_cli_json_and_text_carry_the_warnings",
        "tests/test_calibration_warnings.py::test_good_real_sets_have_no_warning",
        "tests/test_calibration_warnings.py::test_plugin_run_warnings_reach_the_gui",
        "tests/test_calibration_warnings.py::test_wrong_board_size",
        "tests/test_cli.py::test_demo_creates_a_project",
        "tests/test_cli.py::test_errors_are_one_line_on_stderr_with_nonzero_exit",
        "tests/test_cli.py::test_plugins_json_lists_builtins_with_kind_version_status",
        "tests/test_cli.py::test_run_a_plugin_with_declared_parameters",
        "tests/test_cli_kill.py::test_sigkill_of_camcmm_run_keeps_completed_results",
        "tests/test_devices_gui.py::test_catalogue_add_grab_move_and_bad_settings",
        "tests/test_devices_gui.py::test_turntable_through_the_serial_stage_pauses_on_a_killed_simulator_and_resumes",
        "tests/test_devices_sequences.py::test_hung_stage_is_detected_by_its_reply_timeout",
        "tests/test_devices_sequences.py::test_killed_stage_pauses_the_turntable_run_without_losing_frames",
        "tests/test_devices_zaber.py::test_mute_and_hang",
        "tests/test_devices_zaber.py::test_no_reply_is_a_timeout_and_the_late_reply_is_not_taken_for_the_next",
        "tests/test_devices_zaber.py::test_rotary_stage_over_tcp",
        "tests/test_devices_zaber_faults.py::test_cable_pulled_during_a_move[pty]",
        "tests/test_devices_zaber_faults.py::test_cable_pulled_during_a_move[tcp]",
        "tests/test_devices_zaber_faults.py::test_devices_page_shows_the_refusal_as_one_line",
        "tests/test_example_device.py::test_the_devices_page_offers_adds_and_moves_the_lab_device",
        "tests/test_example_plugin.py::test_lab_plugin_is_discovered_and_runs",
        "tests/test_fit_cli.py::test_camcmm_fit_extract_nist_scan",
        "tests/test_fit_cli.py::test_camcmm_fit_subprocess_json",
        "tests/test_fit_cli.py::test_camcmm_fit_subprocess_text_and_errors",
        "tests/test_fit_outliers.py::test_fast_vdi2634_on_a_larger_sphere_equals_the_plugins_naive_loop",
        "tests/test_fit_reference.py::test_uncertainties_match_monte_carlo",
        "tests/test_fit_segment.py::test_ball_bar_segmentation",
        "tests/test_fit_segment.py::test_nist_raw_scan_to_sphere[101]",
        "tests/test_fit_segment.py::test_nist_raw_scan_to_sphere[110]",
        "tests/test_fit_warnings.py::test_gui_shows_the_fit_warnings",
        "tests/test_fit_warnings.py::test_right_element_no_warning[0.05]",
        "tests/test_fit_warnings.py::test_right_element_no_warning[0.0]",
        "tests/test_fit_warnings.py::test_warnings_in_plugin_result_and_cli_json",
        "tests/test_fringe_chain.py::test_an_uncorrected_projector_gamma_ripples_a_flat_under_three_step_phase_shifting[3-1.0-False]",
        "tests/test_fringe_chain.py::test_an_uncorrected_projector_gamma_ripples_a_flat_under_three_step_phase_shifting[3-2.2-True]",
        "tests/test_fringe_chain.py::test_an_uncorrected_projector_gamma_ripples_a_flat_under_three_step_phase_shifting[4-2.2-False]",
        "tests/test_fringe_chain.py::test_phase_noise_is_what_phase_shifting_theory_predicts",
        "tests/test_fringe_chain.py::test_stereo_phase_matching_measures_the_sphere",
        "tests/test_fringe_cli.py::test_patterns_are_written_at_the_projector_resolution",
        "tests/test_fringe_cli.py::test_reconstruct_bad_input_is_one_line",
        "tests/test_fringe_cli.py::test_saturated_captures_are_reported_with_their_fraction",
        "tests/test_fringe_kamino410.py::test_full_captures_decode_like_upstream",
        "tests/test_fringe_kimthyung.py::test_sphere_reconstructs_as_a_sphere",
        "tests/test_fringe_reconstruct.py::test_calibration_that_does_not_fit_the_images_is_refused",
        "tests/test_fringe_reconstruct.py::test_camera_camera_phase_matching_is_on_the_true_surface",
        "tests/test_fringe_reconstruct.py::test_camera_projector_points_are_on_the_true_surface[auto]",
        "tests/test_fringe_reconstruct.py::test_camera_projector_points_are_on_the_true_surface[horizontal]",
        "tests/test_fringe_reconstruct.py::test_camera_projector_points_are_on_the_true_surface[rays]",
        "tests/test_fringe_reconstruct.py::test_camera_projector_points_are_on_the_true_surface[vertical]",
        "tests/test_fringe_reconstruct.py::test_noisy_sphere_radius_through_the_plugin",
        "tests/test_gui_logic.py::test_async_run_reports_progress_from_the_worker_thread",
        "tests/test_gui_logic.py::test_bad_files_give_a_named_error_and_lose_nothing",
        "tests/test_gui_logic.py::test_bad_parameter_is_reported_and_nothing_stored",
        "tests/test_gui_logic.py::test_cancel_a_running_plugin",
        "tests/test_gui_logic.py::test_colour_field_selector_through_state",
        "tests/test_gui_logic.py::test_form_of_every_parameter_type_and_progress",
        "tests/test_gui_logic.py::test_import_cloud_shows_it_coloured_with_legend",
        "tests/test_gui_logic.py::test_import_uploaded_bytes_keeps_the_original_name",
        "tests/test_gui_logic.py::test_mesh_and_image_items",
        "tests/test_gui_logic.py::test_plugin_form_and_run",
        "tests/test_gui_logic.py::test_reopening_the_project_lists_and_shows_its_items",
        "tests/test_gui_logic.py::test_run_without_input_says_what_is_missing",
        "tests/test_inspect_gui.py::test_a_reference_cloud_as_the_nominal",
        "tests/test_inspect_gui.py::test_bad_input_gets_one_line_reasons",
        "tests/test_inspect_gui.py::test_compare_publishes_stats_charts_legend_and_bands",
        "tests/test_inspect_gui.py::test_no_overlap_is_reported_not_coloured",
        "tests/test_inspect_gui.py::test_pick_section_export_report_and_reopen",
        "tests/test_inspect_gui.py::test_point_pairs_picked_in_the_view_align_a_turned_part",
        "tests/test_inspect_gui.py::test_run_async_reports_progress_and_can_be_cancelled",
        "tests/test_inspection_align.py::test_global_rigid_partial_scan",
        "tests/test_inspection_align.py::test_global_similarity_from_anywhere",
        "tests/test_inspection_align.py::test_no_overlap_different_object",
        "tests/test_inspection_align.py::test_no_overlap_disjoint_patches",
        "tests/test_inspection_align.py::test_noise_and_outliers_tukey",
        "tests/test_inspection_align.py::test_open3d_icp_agrees_on_clouds",
        "tests/test_inspection_align.py::test_region_ignores_a_fixture",
        "tests/test_inspection_align.py::test_similarity_icp_recovers_scale",
        "tests/test_inspection_cli.py::test_cli_bad_input",
        "tests/test_inspection_cli.py::test_cli_json_out_and_report",
        "tests/test_inspection_cli.py::test_cli_no_overlap_reports_failure",
        "tests/test_inspection_cli.py::test_cli_pairs",
        "tests/test_inspection_cli.py::test_cli_text_and_similarity",
        "tests/test_inspection_cli.py::test_compare_against_a_reference_cloud",
        "tests/test_inspection_cli.py::test_plugins_through_the_host",
        "tests/test_inspection_cli.py::test_report_renders",
        "tests/test_inspection_coverage.py::test_top_face_of_a_cube",
        "tests/test_inspection_distance.py::test_nearest_triangle_normal_alone_fails_where_we_do_not",
        "tests/test_layering.py::test_every_core_module_imports_on_its_own",
        "tests/test_layering.py::test_no_import_cycles[core]",
        "tests/test_layering.py::test_no_import_cycles[gui]",
        "tests/test_layering.py::test_the_cycle_finder_sees_function_level_and_relative_imports",
        "tests/test_project_crash.py::test_sigkill_while_writing_loses_nothing",
        "tests/test_security.py::test_a_token_beginning_with_a_dash_reaches_wslink",
        "tests/test_security.py::test_https_with_certfile_and_keyfile",
        "tests/test_security.py::test_serve_refuses_bad_options_in_one_line",
        "tests/test_security.py::test_the_page_reaches_only_the_roots_in_each_of_the_three_places",
        "tests/test_security.py::test_the_server_answers_nothing_without_its_token",
        "tests/test_uncertainty_dask.py::test_unreachable_scheduler_is_a_clear_error",
        "tests/test_uncertainty_gui.py::test_budget_editor_reproduces_gum_h1_and_the_cli",
        "tests/test_uncertainty_gui.py::test_budget_edits_evaluate_live_and_bad_cells_name_the_entry",
        "tests/test_uncertainty_gui.py::test_budget_store_and_export",
        "tests/test_uncertainty_gui.py::test_montecarlo_bad_input_is_one_line_and_the_page_keeps_working",
        "tests/test_uncertainty_gui.py::test_montecarlo_cancel_is_said_and_the_next_run_works",
        "tests/test_uncertainty_gui.py::test_montecarlo_run_publishes_plugin_numbers_is_stored_and_restored",
        "tests/test_uncertainty_gum.py::test_budget_cli_subprocess_text",
        "tests/test_vdi2634_bad_input.py::test_each_bad_measurement_has_a_clear_one_line_message",
        "tests/test_vdi2634_cli.py::test_verify_errors_are_one_line",
        "tests/test_vdi2634_cli.py::test_verify_json",
        "tests/test_vdi2634_cli.py::test_verify_text_and_report",
        "tests/test_vdi2634_demo.py::test_demo_contains_a_finished_test",
        "tests/test_vdi2634_demo.py::test_demo_is_not_made_twice",
        "tests/test_vdi2634_part2.py::test_good_system_passes_with_values_at_the_noise_level",
        "tests/test_vdi2634_part2.py::test_scale_error_shows_in_SD_and_PS_by_the_expected_amounts",
        "tests/test_vdi2634_part3.py::test_a_missing_repeat_makes_the_test_incomplete",
        "tests/test_vdi2634_part3.py::test_full_part3_set_with_three_repeats",
        "tests/test_vdi2634_part3.py::test_noise_free_ball_plate_at_scale_037_recovers_the_metric_lengths",
        "tests/test_vdi2634_part3.py::test_outlier_rule_is_the_plans",
        "tests/test_vdi2634_part3.py::test_requirements_for_part3",
        "tests/test_vdi2634_part3.py::test_scaling_uncertainty_enters_U",
        "tests/test_vdi2634_protocol.py::test_wizard_flow_equals_the_batch_run",
        "tests/test_virtuallab_render.py::test_phase_of_a_rendered_flat_is_the_analytic_projector_column",
        "tests/test_virtuallab_render.py::test_projector_defocus_lowers_the_fringe_modulation_as_its_blur_circle_says",
        "tests/test_virtuallab_render.py::test_shadow_of_a_sphere_on_a_plane_is_where_geometry_puts_it",
        "tests/test_wizard.py::test_demo_project_opens_with_a_finished_test",
        "tests/test_wizard.py::test_full_part2_test_with_redo_bad_file_restart_and_report[real]",
        "tests/test_wizard.py::test_page_setup_import_view_and_report[fake]",
        "tests/test_wizard.py::test_page_setup_import_view_and_report[real]",
        "tests/test_wizard.py::test_part3_repeats_and_plan_options",
        "tests/test_wizard_acquire.py::test_the_simulated_fringe_system_is_offered",
        "tests/test_worker.py::test_a_worker_whose_server_was_killed_mid_run_exits",
        "tests/test_worker.py::test_cancel_reaches_the_worker_and_a_stubborn_plugin_is_stopped",
        "tests/test_worker.py::test_native_crash_is_one_line_and_the_next_run_gets_a_fresh_worker",
        "tests/test_worker.py::test_outputs_warnings_progress_and_errors_cross_the_boundary",
        "tests/test_worker.py::test_session_shows_the_crash_as_one_line_and_keeps_working",
        "tests/test_worker_gui.py::test_a_negative_focal_length_calibration_file_through_the_inspect_form",
        "tests/test_worker_gui.py::test_negative_focal_length_is_one_line_and_the_next_measurement_works",
        "tests/test_worker_gui.py::test_the_native_crash_of_issue_13_ends_the_worker_not_the_server",
    }
)


def pytest_collection_modifyitems(config, items):
    """tests/test_browser_*.py -> browser + slow; the node ids in SLOW_TESTS -> slow."""
    for item in items:
        if item.path.name.startswith("test_browser"):
            item.add_marker(pytest.mark.browser)
            item.add_marker(pytest.mark.slow)
        elif item.nodeid.split("[")[0] in SLOW_TESTS or item.nodeid in SLOW_TESTS:
            item.add_marker(pytest.mark.slow)


def cli_json(*args, **kw):
    """``run_camcmm(*args)`` that must succeed; its stdout parsed as the one JSON document."""
    import json

    return json.loads(run_camcmm(*args, **kw).stdout)


def cli_refused(*args, code=None, **kw) -> str:
    """``run_camcmm(*args)`` that must be refused: a non-zero exit (``code`` if given) and one
    stderr line ``camcmm: error: …``, returned."""
    proc = run_camcmm(*args, ok=False, **kw)
    assert proc.returncode != 0 if code is None else proc.returncode == code, (proc.returncode, proc.stderr)
    assert proc.stderr.count("\n") == 1 and proc.stderr.startswith("camcmm: error:"), proc.stderr
    return proc.stderr
