import os
import sys

sys.path.insert(0, os.path.dirname(__file__))

# ROS 2 isolation for tests that use rclpy: a DDS domain of this test process's own, and
# discovery kept on this host (Jazzy's default, SUBNET, multicasts to 239.255.0.1 on the
# network interface). Set before any test module imports rclpy; the environment wins.
os.environ.setdefault("ROS_DOMAIN_ID", str(os.getpid() % 100 + 100))
os.environ.setdefault("ROS_AUTOMATIC_DISCOVERY_RANGE", "LOCALHOST")


def pytest_configure(config):
    config.addinivalue_line("markers", "slow: the slow tier (make test-all): long physics studies and the "
                                       "costlier repeats of fast checks (SLOW); make test skips them")
    config.addinivalue_line("markers", "second_half: run by scripts/test.sh in its second process")
    config.addinivalue_line("markers", "ros: needs the ROS 2 Jazzy wheels and tethernet_msgs (scripts/setup.sh)")
    # lark (rosidl's IDL parser, imported by rclpy) imports modules deprecated in 3.11
    config.addinivalue_line("filterwarnings", "ignore:module 'sre_:DeprecationWarning")


#: core modules that scripts/test.sh runs beside the ROS tests (the longest of them, so
#: that the two halves take about the same time on 2 cores; the fast tier of the run of
#: 2026-12-06 12:57, by its durations: about 550 s each)
BESIDE_ROS = ("test_reproducibility.py", "test_montecarlo_golden.py", "test_montecarlo_cli.py",
              "test_kernel_broadphase.py", "test_optimizer_bayesopt.py", "test_core_statistics.py",
              "test_studies_summary.py", "test_optimizer_golden.py")

#: The slow tier: tests that ``make test`` (CI, the fast tier: -m "not slow") leaves to
#: ``make test-all``, beside those marked ``@pytest.mark.slow`` in their modules. Each one
#: repeats, at a higher cost, what a test of the fast tier checks: another design or seed
#: of the same golden or property, another build of the same machine-independence check,
#: a second kill-and-resume path. Keys: "module::test name" (with its parameters) or
#: "module::" for a whole module; values: the seconds it took on the run of 2026-12-06
#: 12:57 (2 cores, both halves busy), which put it here.
SLOW = {
    "test_core_physics.py::test_no_body_sinks_into_target_under_noise": 38.4,
    "test_core_physics.py::test_no_body_sinks_into_target[mass-min]": 14.3,
    "test_core_physics.py::test_no_body_sinks_into_target[suboptimal]": 11.8,
    "test_core_physics.py::test_no_body_sinks_into_target[time-min]": 11.3,
    "test_core_physics.py::test_time_min_seed_497_no_longer_diverges": 14.3,
    "test_reproducibility.py::test_golden_episode_with_numba_generic_cpu": 108.8,
    "test_reproducibility.py::test_goldens_without_numpy_simd_paths[no-avx512]": 46.5,
    "test_reproducibility.py::test_no_blas_or_lapack_result_reaches_an_episode": 37.2,
    "test_ros_colcon.py::": 128.9,
    "test_montecarlo_cli.py::test_sigterm_stops_the_workers_and_keeps_the_samples": 50.6,
    "test_optimizer_golden.py::test_optimizer_run_machine_independent[real-mass]": 47.6,
    "test_kernel_golden.py::test_episode_bit_identical_to_golden[baseline-None-spec-text]": 13.3,
    "test_kernel_golden.py::test_episode_bit_identical_to_golden[mass-min-None-spec-text]": 12.0,
    "test_kernel_golden.py::test_episode_bit_identical_to_golden[suboptimal-3-spec-text]": 11.2,
    "test_kernel_golden.py::test_episode_bit_identical_to_golden[suboptimal-None-spec-text]": 17.9,
    "test_kernel_golden.py::test_episode_bit_identical_to_golden[time-min-None-spec-text]": 11.8,
    "test_kernel_golden.py::test_episode_bit_identical_to_golden[baseline-3-spec-text]": 21.5,
    "test_kernel_broadphase.py::test_on_off_and_check_give_the_same_bits[tumbling-time-min-5]": 18.2,
    "test_kernel_broadphase.py::test_on_off_and_check_give_the_same_bits[nozzle-baseline-3]": 9.8,
    "test_kernel_broadphase.py::test_on_off_and_check_give_the_same_bits[implicit-baseline-None]": 9.5,
    "test_optimizer_cases.py::test_real_run_killed_mid_design_resumes_to_the_same_result": 23.0,
    "test_optimizer_cases.py::test_synthetic_run_kill_and_resume_matches_uninterrupted[False]": 22.7,
    "test_optimizer_cases.py::test_validation_stops_at_the_failure_that_decides_it": 20.9,
    "test_optimizer_cases.py::test_cli_status_reads_the_run_directory": 19.1,
    "test_optimizer_cases.py::test_candidates_validated_in_turn_until_one_meets_the_requirement": 15.8,
    "test_ros_dead_node.py::test_a_killed_node_aborts_the_capture_naming_it[monitor_node]": 13.0,
    "test_ros_dead_node.py::test_a_killed_node_aborts_the_capture_naming_it[actuator_node]": 12.7,
    "test_ros_loop.py::test_user_controller_measured_through_two_suites": 23.2,
    "test_core_batch.py::test_every_lane_is_its_single_episode_bit_for_bit[1]": 8.0,
    "test_core_batch.py::test_every_lane_is_its_single_episode_bit_for_bit[4]": 8.3,
    "test_studies_summary.py::test_a_study_takes_its_finished_cells_from_the_summary": 34.0,
    "test_core_implicit.py::test_deployment_and_closing_time_agree_with_the_explicit_method[mass-min]": 12.2,
    "test_core_tug.py::test_batch_lanes_equal_single_runs_with_the_test": 18.5,
    "test_core_tug.py::test_explicit_method_runs_the_test_and_conserves_momentum": 11.2,
}


def pytest_collection_modifyitems(config, items):
    """Every test of a ``test_ros_*`` module carries the ``ros`` marker, the tests that
    scripts/test.sh runs in its second process (the ROS tests, in file order as some of
    them require, and the modules of :data:`BESIDE_ROS`) the ``second_half`` marker, and
    the tests of :data:`SLOW` the ``slow`` marker."""
    import pytest

    unmatched = set(SLOW)
    for item in items:
        for key in (f"{item.path.name}::{item.name}", f"{item.path.name}::"):
            if key in SLOW:
                item.add_marker(pytest.mark.slow)
                unmatched.discard(key)
        if item.path.name.startswith("test_ros_") and not item.get_closest_marker("ros"):
            item.add_marker(pytest.mark.ros)
        if item.get_closest_marker("ros") or item.path.name in BESIDE_ROS:
            item.add_marker(pytest.mark.second_half)
    collected = {item.path.name for item in items}
    if unmatched and len(collected) > 1 and not config.option.keyword:
        # a test renamed or removed must leave SLOW too (a whole-suite collection only)
        gone = sorted(k for k in unmatched if k.split("::")[0] in collected)
        if gone:
            raise pytest.UsageError(f"tests/conftest.py SLOW names tests that do not exist: {gone}")
