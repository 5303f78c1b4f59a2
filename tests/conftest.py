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

    proc = subprocess.run([sys.executable, "-m", "camcmm", *map(str, args)], capture_output=True, text=True,
                          timeout=timeout, **kw)
    if ok:
        assert proc.returncode == 0, proc.stderr
    return proc


# -- marks by rule ---------------------------------------------------------------------------------
# `pytest -m "not slow"` is the quick run (under two minutes on the 2-core reference machine).
# The browser tests are marked here by their file name; the other slow ones by their node id below,
# so that the list lives in one place: measured with `pytest --durations=0` on 2026-11-25 on the
# 2-core machine shared with seven other runs (load 5-12), every test whose call took >= 8 s there
# (about 1.5-2 s on an idle machine), and the tests sharing a module fixture that takes that long.
# A parametrized test is listed by its full id, or by its name for every parameter.
SLOW_TESTS: frozenset[str] = frozenset({
    "tests/test_calibration_camera.py::test_detection_matches_exact_projection[chessboard:9x6:20-450]",
    "tests/test_calibration_cli.py::test_bad_input",
    "tests/test_calibration_cli.py::test_scale_and_gauge_block",
    "tests/test_calibration_gui.py::test_bad_input_gives_one_line_and_the_page_keeps_working",
    "tests/test_calibration_gui.py::test_camera_shows_the_plugins_numbers_corners_and_heat_map",
    "tests/test_calibration_gui.py::test_images_from_an_upload_and_from_the_project_items",
    "tests/test_calibration_gui.py::test_stereo_pair_pose_epipolar_and_rectified_pair",
    "tests/test_calibration_gui.py::test_stored_downloaded_used_by_a_system_and_restored",
    "tests/test_calibration_real.py::test_bouguet_example",
    "tests/test_calibration_triangulation.py::test_covariance_against_monte_carlo",
    "tests/test_calibration_uncertainty.py::test_projection_uncertainty_monte_carlo",
    "tests/test_calibration_uncertainty.py::test_stereo_uncertainty_monte_carlo",
    "tests/test_calibration_warnings.py::test_bouguet_example_has_no_warning",
    "tests/test_calibration_warnings.py::test_calibration_page_shows_the_warnings",
    "tests/test_calibration_warnings.py::test_cli_json_and_text_carry_the_warnings",
    "tests/test_cli.py::test_demo_creates_a_project",
    "tests/test_cli.py::test_errors_are_one_line_on_stderr_with_nonzero_exit",
    "tests/test_cli.py::test_plugins_json_lists_builtins_with_kind_version_status",
    "tests/test_cli.py::test_run_a_plugin_with_declared_parameters",
    "tests/test_cli_kill.py::test_sigkill_of_camcmm_run_keeps_completed_results",
    "tests/test_devices_zaber_faults.py::test_devices_page_shows_the_refusal_as_one_line",
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
    "tests/test_fringe_chain.py::test_an_uncorrected_projector_gamma_ripples_a_flat_under_three_step_phase_shifting[3-1.0-False]",
    "tests/test_fringe_chain.py::test_an_uncorrected_projector_gamma_ripples_a_flat_under_three_step_phase_shifting[3-2.2-True]",
    "tests/test_fringe_chain.py::test_an_uncorrected_projector_gamma_ripples_a_flat_under_three_step_phase_shifting[4-2.2-False]",
    "tests/test_fringe_chain.py::test_stereo_phase_matching_measures_the_sphere",
    "tests/test_fringe_cli.py::test_patterns_are_written_at_the_projector_resolution",
    "tests/test_fringe_cli.py::test_reconstruct_bad_input_is_one_line",
    "tests/test_fringe_cli.py::test_saturated_captures_are_reported_with_their_fraction",
    "tests/test_fringe_kamino410.py::test_full_captures_decode_like_upstream",
    "tests/test_fringe_kimthyung.py::test_sphere_reconstructs_as_a_sphere",
    "tests/test_fringe_reconstruct.py::test_calibration_that_does_not_fit_the_images_is_refused",
    "tests/test_fringe_reconstruct.py::test_camera_projector_points_are_on_the_true_surface[auto]",
    "tests/test_fringe_reconstruct.py::test_camera_projector_points_are_on_the_true_surface[horizontal]",
    "tests/test_fringe_reconstruct.py::test_camera_projector_points_are_on_the_true_surface[rays]",
    "tests/test_fringe_reconstruct.py::test_camera_projector_points_are_on_the_true_surface[vertical]",
    "tests/test_fringe_reconstruct.py::test_noisy_sphere_radius_through_the_plugin",
    "tests/test_gui_logic.py::test_async_run_reports_progress_from_the_worker_thread",
    "tests/test_gui_logic.py::test_bad_files_give_a_named_error_and_lose_nothing",
    "tests/test_gui_logic.py::test_bad_parameter_is_reported_and_nothing_stored",
    "tests/test_gui_logic.py::test_colour_field_selector_through_state",
    "tests/test_gui_logic.py::test_form_of_every_parameter_type_and_progress",
    "tests/test_gui_logic.py::test_import_cloud_shows_it_coloured_with_legend",
    "tests/test_gui_logic.py::test_import_uploaded_bytes_keeps_the_original_name",
    "tests/test_gui_logic.py::test_mesh_and_image_items",
    "tests/test_gui_logic.py::test_plugin_form_and_run",
    "tests/test_gui_logic.py::test_reopening_the_project_lists_and_shows_its_items",
    "tests/test_gui_logic.py::test_run_without_input_says_what_is_missing",
    "tests/test_inspect_gui.py::test_a_reference_cloud_as_the_nominal",
    "tests/test_inspect_gui.py::test_compare_publishes_stats_charts_legend_and_bands",
    "tests/test_inspect_gui.py::test_no_overlap_is_reported_not_coloured",
    "tests/test_inspect_gui.py::test_pick_section_export_report_and_reopen",
    "tests/test_inspect_gui.py::test_point_pairs_picked_in_the_view_align_a_turned_part",
    "tests/test_inspection_align.py::test_global_rigid_partial_scan",
    "tests/test_inspection_align.py::test_global_similarity_from_anywhere",
    "tests/test_inspection_align.py::test_no_overlap_different_object",
    "tests/test_inspection_align.py::test_no_overlap_disjoint_patches",
    "tests/test_inspection_align.py::test_noise_and_outliers_tukey",
    "tests/test_inspection_align.py::test_open3d_icp_agrees_on_clouds",
    "tests/test_inspection_cli.py::test_cli_bad_input",
    "tests/test_inspection_cli.py::test_cli_json_out_and_report",
    "tests/test_inspection_cli.py::test_cli_no_overlap_reports_failure",
    "tests/test_inspection_cli.py::test_cli_pairs",
    "tests/test_inspection_cli.py::test_cli_text_and_similarity",
    "tests/test_inspection_cli.py::test_compare_against_a_reference_cloud",
    "tests/test_inspection_coverage.py::test_top_face_of_a_cube",
    "tests/test_layering.py::test_every_core_module_imports_on_its_own",
    "tests/test_security.py::test_https_with_certfile_and_keyfile",
    "tests/test_vdi2634_demo.py::test_demo_contains_a_finished_test",
    "tests/test_vdi2634_demo.py::test_demo_is_not_made_twice",
    "tests/test_vdi2634_part3.py::test_a_missing_repeat_makes_the_test_incomplete",
    "tests/test_vdi2634_part3.py::test_full_part3_set_with_three_repeats",
    "tests/test_vdi2634_part3.py::test_outlier_rule_is_the_plans",
    "tests/test_vdi2634_part3.py::test_requirements_for_part3",
    "tests/test_vdi2634_part3.py::test_scaling_uncertainty_enters_U",
    "tests/test_wizard.py::test_demo_project_opens_with_a_finished_test",
    "tests/test_wizard.py::test_full_part2_test_with_redo_bad_file_restart_and_report[real]",
    "tests/test_wizard.py::test_page_setup_import_view_and_report[fake]",
    "tests/test_wizard.py::test_page_setup_import_view_and_report[real]",
    "tests/test_wizard.py::test_part3_repeats_and_plan_options",
    "tests/test_worker_gui.py::test_the_native_crash_of_issue_13_ends_the_worker_not_the_server",
})


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
