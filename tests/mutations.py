"""The one-line bugs a mutation probe once let through the suite, each with the test that
now catches it.

Run from the repository root (``make setup`` first)::

    .venv/bin/python tests/mutations.py [N ...]

For each mutation (the N-th ones only, counted from 1 as it prints them, where N are given)
it edits the line, runs the tests named for it (``pytest -x``), restores the file and prints
``killed`` (a test failed, as it must) or ``SURVIVED``; the exit code is the number that
survived.  The files are restored even when interrupted.  Not collected by pytest (no
``test_`` prefix): each mutation runs part of the suite.
"""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]

#: (file, text, mutated text, tests that must fail): the issue's 15 survivors, then those
#: of a later probe, then those of a probe of 28 (the settled tail's constant, the
#: autopilot's record, a shared flight's wall time, an actuator fault's onset step, a
#: reference's divergence in a chunk).
MUTATIONS = [
    (
        "probing/core/isolation.py",
        "span = range(first_alarm - lookback, first_alarm + verdict_periods + 1)",
        "span = range(first_alarm - lookback, first_alarm + verdict_periods)",
        "tests/core/test_isolation.py::test_the_verdict_looks_from_lookback_before_to_verdict_periods_after",
    ),
    (
        "probing/core/detection.py",
        "full = np.minimum(m, w)",
        "full = np.minimum(m, w - 1)",
        "tests/core/test_detection.py::test_the_model_is_the_detectors_own_rate",
    ),
    (
        "probing/core/monitor.py",
        "len(self._since_alarm) < self.isolation_periods",
        "len(self._since_alarm) <= self.isolation_periods",
        "tests/core/test_detector.py::test_isolation_rests_on_exactly_the_periods_after_the_first_alarm",
    ),
    (
        "probing/core/monitor.py",
        "1.0 - self.shape_alpha / 2",
        "1.0 - self.shape_alpha",
        "tests/core/test_detector.py::test_a_surface_is_lost_inside_the_two_sided_t_interval_of_zero",
    ),
    (
        "probing/sim/world.py",
        "if step >= onset >= 0:",
        "if step > onset >= 0:",
        "tests/sim/test_control.py::test_an_actuator_fault_acts_from_the_exact_step_of_its_onset",
    ),
    (
        "probing/sim/surfaces.py",
        '"fcs/right-aileron-pos-deg",',
        '"fcs/left-aileron-pos-deg",',
        "tests/experiment/test_surfaces.py::test_the_aileron_driven_and_measured_is_the_right_panel",
    ),
    (
        "probing/sim/flight.py",
        "return onset_step(self.damage_onset_s, self.dt_s)",
        "return onset_step(self.damage_onset_s, self.dt_s) + 1",
        "tests/sim/test_plant.py::test_a_scheduled_damage_is_switched_on_at_the_step_that_starts_at_its_onset",
    ),
    (
        "probing/experiment/flight/monitor.py",
        "settings.alpha(self.period_s, len(self.monitored))",
        "settings.alpha(self.period_s, len(channels))",
        "tests/experiment/test_monitor.py::test_the_false_alarm_rate_is_shared_by_the_monitored_channels_only",
    ),
    (
        "probing/experiment/flight/monitor.py",
        "time_s = (p + 1) * self.period_s",
        "time_s = p * self.period_s",
        "tests/experiment/test_monitor.py::test_the_first_alarms_row_ends_at_the_reported_first_alarm",
    ),
    (
        "probing/experiment/design/design.py",
        "while (2**order - 1) * t0 < short_period_settling_s:",
        "while (2**order) * t0 < short_period_settling_s:",
        "tests/experiment/test_design.py::test_the_order_is_the_smallest_whose_period_covers_the_short_period",
    ),
    (
        "probing/experiment/output/scatter.py",
        "acov[: extra.size] += extra",
        "acov[: extra.size] = extra",
        "tests/experiment/test_prediction.py::test_extra_noise_adds_to_the_sensor_noise",
    ),
    (
        "probing/experiment/scenario/schema.py",
        "    if value >= duration_s:",
        "    if value > duration_s:",
        "tests/experiment/test_scenario.py::test_a_fault_onset_must_come_before_the_run_ends",
    ),
    (
        "probing/experiment/output/storage.py",
        "            w.abort()",
        "            pass",
        "tests/experiment/test_storage.py::test_a_failed_run_leaves_nothing_half_written",
    ),
    (
        "probing/experiment/flight/run.py",
        "if all(r.diverged for r in readers):",
        "if any(r.diverged for r in readers):",
        "tests/sweep/test_flight_families.py::test_references_of_one_flight_write_what_they_write_alone",
    ),
    (
        "probing/experiment/flight/run.py",
        "r.computer.finish(r.outputs, r.diverged or rig.ended)",
        "r.computer.finish(r.outputs, rig.ended)",
        "tests/sweep/test_flight_families.py::test_references_of_one_flight_write_what_they_write_alone",
    ),
    (
        "probing/experiment/flight/run.py",
        "commanded=rig.autopilot is not None,",
        "commanded=None,",
        "tests/sweep/test_flight_families.py::test_references_of_one_flight_write_what_they_write_alone",
    ),
    (
        "probing/sweep/tasks.py",
        "Path(task.failed_file).unlink(missing_ok=True)",
        "pass",
        "tests/sweep/test_sweep.py::test_a_retry_that_succeeds_removes_the_old_failure_record",
    ),
    (
        "probing/experiment/flight/onboard.py",
        "deviation = actuator_deviation(*values, servo=self.servo)",
        "deviation = actuator_deviation(*values)",
        "tests/experiment/test_isolation_flights.py::test_each_fault_class_gets_its_verdict[case6]",
    ),
    (
        "probing/analysis/monitoring.py",
        "healthy = periods[periods.time_s <= onset]",
        "healthy = periods[periods.time_s < onset]",
        "tests/analysis/test_monitoring.py::test_a_period_ending_at_the_onset_is_healthy",
    ),
    (
        "probing/analysis/monitoring.py",
        "first_alarm is not None and first_alarm > onset",
        "first_alarm is not None and first_alarm >= onset",
        "tests/analysis/test_monitoring.py::test_a_first_alarm_at_the_onset_gives_no_verdict_for_the_fault",
    ),
    (
        "probing/sim/gust_twin.py",
        '*(GUST_INPUTS[f"{a}_gust_rad_s"] for a in "pqr"),',
        '*(GUST_INPUTS[f"{a}_gust_rad_s"] for a in "prq"),',
        "tests/sim/test_gust_twin.py::test_each_rotational_gust_reaches_its_own_axis_of_the_model",
    ),
    (
        "probing/experiment/recorded/analyze.py",
        "    return y - y.mean(axis=0)",
        "    return y - y.mean()",
        "tests/experiment/test_analyze.py::test_each_output_loses_a_constant_of_its_own",
    ),
    (
        "probing/experiment/recorded/foreign_log.py",
        "before = (t <= 0) & (t > -how.trim_mean_before_s)",
        "before = (t < 0) & (t > -how.trim_mean_before_s)",
        "tests/experiment/test_foreign_log.py::test_the_trim_reading_is_the_mean_of_the_rows_up_to_time_0",
    ),
    (
        "probing/experiment/design/design_window.py",
        "else min(met, key=_amplitude)",
        "else max(met, key=_amplitude)",
        "tests/experiment/test_design_window.py::test_when_the_last_flight_misses_the_smallest_amplitude_that_met_the_goal_is_taken",
    ),
    (
        "probing/experiment/design/design_window.py",
        "for p in range(first, scn.periods)",
        "for p in range(0, scn.periods)",
        "tests/experiment/test_design_window.py::test_the_per_period_gain_scatter_is_that_of_the_settled_periods_alone",
    ),
    (
        "probing/analysis/excitations.py",
        "float(gains.std(ddof=1))",
        "float(gains.std(ddof=0))",
        "tests/analysis/test_excitation_table.py::test_the_gain_scatter_over_seeds_is_the_sample_standard_deviation",
    ),
    (
        "probing/analysis/monitoring.py",
        '"alpha_check": _alpha(CHECK_RATE_PER_HOUR, period_s, channels)',
        '"alpha_check": _alpha(CHECK_RATE_PER_HOUR, period_s, 1)',
        "tests/analysis/test_monitoring.py::test_the_threshold_laws_false_alarm_budget_is_shared_by_the_monitored_channels",
    ),
    (
        "probing/api/flight.py",
        "(staging / name).write_bytes(self._files[name])",
        "(staging / name).write_bytes(self._files[name][:-1])",
        "tests/api/test_api.py::test_a_saved_flight_is_probing_run_byte_for_byte[a_deadband]",
    ),
    (
        "probing/api/calls.py",
        "timeseries=how.timeseries is not False,",
        "timeseries=bool(how.timeseries),",
        "tests/api/test_api.py::test_a_saved_flight_is_probing_run_byte_for_byte[a_deadband]",
    ),
    (
        "probing/analysis/analyze_plots.py",
        '& (prediction["period"] >= settle_periods)',
        '& (prediction["period"] > settle_periods)',
        "tests/api/test_api.py::test_plot_draws_each_channel_with_its_bounds_and_the_truth_once_computed",
    ),
    (
        "probing/experiment/output/staging.py",
        'remove_dead_writers_files(place, ".tmp", folders=True)',
        "None",
        "tests/experiment/test_work_folder.py::test_a_dead_writers_work_folder_is_removed_and_a_live_ones_kept",
    ),
    (
        "probing/core/pinning.py",
        "constant = np.where(settled, own[:, :, 0].mean(axis=0), 0.0)",
        "constant = np.where(settled, own[0, :, 0], 0.0)",
        "tests/core/test_pinning.py::test_the_constant_removed_is_the_mean_over_periods_of_each_periods_tail_mean",
    ),
    (
        "probing/sim/autopilot.py",
        "kept.append(u_el if by_elevator else asked - trim_pos)",
        "kept.append(u_el if by_elevator else asked)",
        "tests/sim/test_autopilot.py::test_the_probed_surfaces_command_is_recorded_as_its_change_from_trim",
    ),
    (
        "probing/sweep/tasks.py",
        "wall = (time.perf_counter() - t0) / len(todo)",
        "wall = time.perf_counter() - t0",
        "tests/sweep/test_sweep.py::test_each_task_of_a_shared_flight_records_its_share_of_the_flights_wall_time",
    ),
    (
        "probing/core/faults.py",
        "return round(onset_s / dt_s)",
        "return math.ceil(onset_s / dt_s)",
        "tests/core/test_faults.py::test_a_fault_acts_from_the_step_that_starts_at_its_onset",
    ),
    (
        "probing/experiment/flight/live.py",
        "if self.steps >= self.fault_onset >= 0:",
        "if self.steps > self.fault_onset >= 0:",
        "tests/experiment/test_live.py::test_the_live_worlds_actuator_fault_acts_from_the_exact_step_of_its_onset",
    ),
    (
        "probing/experiment/flight/flight_computer.py",
        'raise ReferenceDiverged(f"the reference: {done.ended}")',
        "pass",
        "tests/experiment/test_flight_computer.py::test_a_reference_diverging_in_a_chunk_ends_the_flight_at_that_chunk",
    ),
]


def _pytest(test: str) -> subprocess.CompletedProcess[str]:
    cmd = [sys.executable, "-m", "pytest", test, "-x", "-q", "-p", "no:cacheprovider"]
    return subprocess.run(cmd, cwd=ROOT, capture_output=True, text=True)


def main(numbers: list[int] | None = None) -> int:
    """Apply each mutation in turn (``numbers``: the N-th ones only, from 1); print what
    caught it; return how many survived."""
    survived = 0
    for i, (file, text, mutated, test) in enumerate(MUTATIONS, 1):
        if numbers and i not in numbers:
            continue
        path = ROOT / file
        original = path.read_text()
        if original.count(text) != 1:
            print(f"{i:2d} {file}: the line is gone or not unique: {text!r}")
            survived += 1
            continue
        if _pytest(test).returncode != 0:
            print(f"{i:2d} {file}: {test} fails without the mutation")
            survived += 1
            continue
        try:
            path.write_text(original.replace(text, mutated))
            run = _pytest(test)
        finally:
            path.write_text(original)
        failed = next((ln for ln in run.stdout.splitlines() if ln.startswith("FAILED")), "")
        verdict = "killed" if run.returncode == 1 else f"SURVIVED (pytest exit {run.returncode})"
        survived += verdict != "killed"
        print(f"{i:2d} {file}: {text!r} -> {mutated!r}: {verdict} {failed}", flush=True)
    return survived


if __name__ == "__main__":
    sys.exit(main([int(n) for n in sys.argv[1:]]))
