"""The `design` fixture (the designs of tests/designs.py's OPTICS) and the hypothesis
profiles.

Hypothesis profiles: ``ci`` (derandomized: the same examples on every run, no example
database) is loaded when the environment variable ``CI`` is set, as it is in ``.ci/run``;
``dev`` (random examples, failures replayed from the local database) otherwise.
``HYPOTHESIS_PROFILE=ci bash tests/run.sh`` reproduces a CI run locally.
"""

from __future__ import annotations

import math
import os
from pathlib import Path

import pytest
from hypothesis import settings

import splitlf._progress
from designs import OPTICS
from splitlf import Camera

settings.register_profile("ci", derandomize=True, database=None, print_blob=True)
settings.register_profile("dev")
settings.load_profile(os.environ.get("HYPOTHESIS_PROFILE", "ci" if os.environ.get("CI") else "dev"))


@pytest.fixture(params=sorted(OPTICS))
def design(request) -> Camera:
    return OPTICS[request.param]()


@pytest.fixture(autouse=True)
def _no_progress_lines(monkeypatch):
    """Progress lines (splitlf._progress, when stderr is no terminal) begin once a run has
    lasted LINE_QUIET seconds: never in tests, so that a run slowed by a loaded machine
    does not change the output a test checks (the tests of the lines set it themselves)."""
    monkeypatch.setattr(splitlf._progress, "LINE_QUIET", math.inf)


#: The slow tier (pytest marker ``slow``; ``bash tests/run.sh --slow``): tests measured at
#: 5 s or more (seconds, setup included, on 2 cores shared with other work, so about 2-3x
#: an idle machine's), besides those that carry ``@pytest.mark.slow`` themselves. Kept
#: here, by node id, so that a parametrized test's slow cases go to the slow tier and its
#: quick ones stay in the default run.
SLOW = {
    'test_render_sat.py::test_closed_form_is_the_quadrature_to_tol[512-rect_sensor]': 18,
    'test_render_sat.py::test_closed_form_at_a_tight_tolerance': 8,
    'test_merits.py::test_expected_error_is_the_dense_closed_form[3.0]': 25,
    'test_merits.py::test_expected_error_is_the_dense_closed_form[300.0]': 25,
    'test_merits.py::test_expected_error_with_a_floor_is_the_dense_closed_form': 25,
    'test_merits.py::test_edge_response_is_the_dense_estimators_mean': 25,
    'test_merits.py::test_least_error_lambda_is_the_closed_forms_minimum': 25,
    'test_merits.py::test_gcv_lambda_is_the_expected_scores_minimum[gcv-1.0]': 55,
    'test_merits.py::test_gcv_lambda_is_the_expected_scores_minimum[weighted gcv-2.0]': 55,
    'test_merits.py::test_expected_error_with_a_measured_spectrum_is_the_dense_closed_form': 25,
    'test_merits.py::test_gcv_parabolic_step_is_the_vertex_through_the_decades': 136,
    'test_evaluate.py::test_sweep_image_merit_is_image_merits': 35,
    'test_evaluate.py::test_compare_table_lists_the_image_merits': 75,
    'test_merits.py::test_image_merits_rows_and_checks': 35,
    'test_explore.py::test_image_view_is_the_api_and_the_button_plots_it': 27,
    'test_explore.py::test_image_quality_button_in_the_page': 30,
    'test_merits.py::test_rows_of_the_same_pixels_are_one_computation': 55,
    'test_colour.py::test_a_colour_is_reconstructed_from_its_own_pixels_only[sensor]': 15,
    'test_colour.py::test_colour_reconstruction_against_the_full_grey_raw': 25,
    'test_render_falloff.py::test_mc_illum_image': 26,
    'test_reconstruct.py::test_tiles_are_the_one_solve[642.0]': 26,
    'test_reconstruct.py::test_tiles_are_the_one_solve[1000.0]': 38,
    'test_reconstruct_noise.py::test_fixed_lambda_is_the_chosen_one_bit_for_bit': 26,
    'test_reconstruct_noise.py::test_cli_carries_the_noise': 14,
    'test_reconstruct_noise.py::test_more_data_never_hurts_at_the_chosen_weights[642.0-True]': 123,
    'test_reconstruct_noise.py::test_more_data_never_hurts_at_the_chosen_weights[642.0-False]': 264,
    'test_reconstruct_noise.py::test_more_data_never_hurts_at_the_chosen_weights[1000.0-True]': 137,
    ('test_reconstruct_noise.py::test_more_data_never_hurts_at_the_chosen_weights'
     '[1000.0-False]'): 227,
    'test_reconstruct_noise.py::test_chosen_weight_is_near_the_oracle[642.0-True]': 22,
    'test_reconstruct_noise.py::test_chosen_weight_is_near_the_oracle[642.0-False]': 43,
    'test_reconstruct_noise.py::test_chosen_weight_is_near_the_oracle[1000.0-True]': 35,
    'test_reconstruct_noise.py::test_chosen_weight_is_near_the_oracle[1000.0-False]': 80,
    'test_cli.py::test_reconstruct_cli_matches_api': 74,
    'test_cli_errors.py::test_simulate_no_conventional': 6,
    'test_compare.py::test_mtf50_where_the_simulation_applies': 31,
    'test_depth.py::test_bad_input': 5,
    'test_depth.py::test_end_to_end_image_at_1m': 21,
    'test_depth_surface.py::test_image_from_the_estimates_own_surface': 67,
    'test_depth_surface.py::test_steep_plane_across_the_out_of_focus_plane': 32,
    'test_depth.py::test_fronto_plane_depth[1000.0-0.01-0.03-0.8]': 20,
    'test_depth.py::test_fronto_plane_depth[1600.0-0.02-0.06-0.0]': 21,
    'test_depth.py::test_fronto_plane_depth[400.0-0.01-0.03-0.8]': 20,
    'test_depth.py::test_sensor_layout_keeps_pixels_of_one_lens': 21,
    'test_depth.py::test_slanted_plane_depth': 19,
    'test_depth.py::test_textureless_cells_are_not_confident': 32,
    'test_design_cli.py::test_cli_simulate_of_a_preset_equals_the_api': 9,
    'test_design_cli.py::test_plot_resolution_of_a_design_draws_the_simulation': 19,
    'test_design_cli.py::test_plot_resolution_of_camera_design_equals_the_camera_figure': 12,
    'test_design_simulate.py::test_camera_simulation_is_the_seed_design_simulation[150.0-None]': 13,
    'test_design_simulate.py::test_camera_simulation_is_the_seed_design_simulation[400.0-noise1]': 6,  # noqa: E501
    'test_design_simulate.py::test_camera_simulation_is_the_seed_design_simulation[642.0-None]': 6,
    'test_design_simulate.py::test_without_the_conventional_row_every_other_row_is_unchanged[subject1-150.0-None]': 9,  # noqa: E501
    'test_docs.py::test_markdown_code_blocks_run[README.md]': 5,
    'test_docs.py::test_markdown_code_blocks_run[architectures.md]': 19,
    'test_docs.py::test_markdown_code_blocks_run[compare.md]': 7,
    'test_docs.py::test_markdown_code_blocks_run[optimise.md]': 28,
    'test_fuzz.py::test_new_samples_union_bounds': 5,
    'test_fuzz.py::test_union_max_gap_at_most_each_half': 5,
    'test_prior.py::test_reconstruct_passes_the_prior_through': 10,
    'test_prior.py::test_tiles_take_the_prior': 15,
    'test_reconstruct.py::test_depth_map_seen_once_against_monte_carlo': 61,
    'test_reconstruct.py::test_general_map_is_the_render_on_a_slanted_plane': 21,
    'test_reconstruct.py::test_general_map_is_the_render_on_hex_and_circle': 37,
    'test_reconstruct.py::test_lens_types_use_only_their_lenses[raytrix-r12 (general route)]': 268,
    'test_reconstruct.py::test_lens_types_use_only_their_lenses[rect two types, tilted plane (tilted route)]': 26,  # noqa: E501
    'test_reconstruct.py::test_more_data_never_hurts[642.0]': 42,
    'test_reconstruct.py::test_noise_stop_moves_the_image_far_less_than_its_error[1000.0-None]': 7,
    'test_reconstruct.py::test_reconstruct_a_monte_carlo_raw': 8,
    'test_reconstruct.py::test_reconstruct_a_monte_carlo_raw_of_a_slanted_plane[0.0-10.0]': 9,
    'test_reconstruct.py::test_reconstruct_a_monte_carlo_raw_of_a_slanted_plane[0.5-10.0]': 11,
    'test_reconstruct.py::test_reconstruct_a_monte_carlo_raw_of_a_slanted_plane[10.0-0.0]': 11,
    'test_reconstruct.py::test_tilted_map_in_both_axes_is_the_render[-20.0-1.0]': 78,
    'test_reconstruct.py::test_tilted_map_in_both_axes_is_the_render[0.6-20.0]': 32,
    'test_reconstruct.py::test_tilted_map_in_both_axes_is_the_render[12.0-12.0]': 108,
    'test_reconstruct.py::test_tilted_map_in_both_axes_is_the_render[8.0-20.0]': 67,
    'test_reconstruct.py::test_tilted_map_is_the_render[-15.0-0.0-region3-0.05]': 94,
    'test_reconstruct.py::test_tilted_map_is_the_render[0.0--15.0-region1-0.05]': 22,
    'test_reconstruct.py::test_tilted_map_is_the_render[0.0-25.0-region0-0.07]': 20,
    'test_reconstruct.py::test_tilted_map_is_the_render[25.0-0.0-region2-0.07]': 69,
    'test_render_accuracy.py::test_general_route_on_a_fronto_plane[1000.0]': 13,
    'test_render_accuracy.py::test_general_route_on_a_fronto_plane[400.0]': 12,
    'test_render_accuracy.py::test_general_route_on_a_fronto_plane[700.0]': 8,
    'test_render_accuracy.py::test_general_route_on_a_fronto_plane[800.0]': 9,
    'test_render_accuracy.py::test_mc_depth_map': 202,
    'test_render_accuracy.py::test_mc_cliff_map': 75,
    'test_render_accuracy.py::test_mc_hex_sensor_spill': 43,
    'test_render_api.py::test_cli_render_with_a_preset_noise_png_and_json': 40,
    'test_render_api.py::test_cli_render_writes_a_raw_file[edge-MAP.npy]': 313,
    'test_render_api.py::test_cli_render_writes_a_raw_file[star-1000]': 7,
    'test_render_api.py::test_render_gives_one_raw_per_channel_in_the_layout[r12]': 89,
    'test_render_api.py::test_render_gives_one_raw_per_channel_in_the_layout[seed]': 9,
    'test_simulate.py::test_cli_simulate': 5,
    'test_simulate.py::test_cli_simulate_out': 6,
    'test_simulate.py::test_split_recovers_band_limited_texture_where_union_resolves': 7,
    'test_simulate.py::test_textures': 6,
    "test_docs.py::test_markdown_code_blocks_run[reconstruct.md]": 30,
    "test_render_accuracy.py::test_general_route_of_a_texture_of_x[texture0]": 7,
    "test_render_accuracy.py::test_general_route_of_a_texture_of_x[texture1]": 9,
    "test_render_accuracy.py::test_general_route_of_a_texture_of_x[texture2]": 9,
}


def pytest_collection_modifyitems(config: pytest.Config, items: list[pytest.Item]) -> None:
    here = Path(__file__).parent
    for item in items:
        nodeid = Path(item.path).relative_to(here).as_posix() + item.nodeid.partition("::")[1] \
            + item.nodeid.partition("::")[2]
        if nodeid in SLOW:
            item.add_marker(pytest.mark.slow)
