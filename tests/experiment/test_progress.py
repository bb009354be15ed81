"""The sweep's ETA against the closed form: runs of a known length finishing in chunks."""

from __future__ import annotations

import io

import pytest

from probing.experiment.output import progress


def test_eta_of_chunks_finishing_together_is_the_time_left(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    """1930 runs of 1 s on 2 workers, reported 64 at a time as each worker ends a chunk (a
    chunk's runs come back together).  The sweep takes 965 s; after r rounds (128 r runs)
    965 - 64 r s are left.  The ETA measured as time elapsed per run reported said
    64 x 1929 = 123,456 s after the first run of the first chunk, and twice the time left
    once that chunk was in."""
    n, wall, workers, chunk = 1930, 1.0, 2, 64
    clock = [0.0]
    monkeypatch.setattr(progress.time, "perf_counter", lambda: clock[0])
    out = io.StringIO()
    bar = progress.Progress(n, "s", "runs", out, enabled=False, lines=True, workers=workers)
    assert bar.eta_s() is None  # nothing finished: no estimate
    done = 0
    for r in range(1, n // (workers * chunk) + 1):
        clock[0] = r * chunk * wall  # both workers end a chunk
        for _ in range(workers * chunk):
            bar.advance(1, "point", wall_s=wall)
            done += 1
            left = (n - done) * wall / workers
            assert bar.eta_s() == pytest.approx(left)
        assert bar.eta_s() == pytest.approx(n * wall / workers - clock[0])
    first = out.getvalue().splitlines()[1]
    assert first.startswith("s: 1/1930 runs, ETA 964 s"), first


def test_runs_without_a_time_do_not_count(monkeypatch: pytest.MonkeyPatch) -> None:
    """Skipped and broken runs (no wall time) count as done but not in the mean."""
    bar = progress.Progress(10, "s", "runs", io.StringIO(), enabled=False, workers=2)
    bar.advance(1, wall_s=float("nan"))
    assert bar.eta_s() is None
    bar.advance(1, wall_s=4.0)
    assert bar.eta_s() == pytest.approx(8 * 4.0 / 2)


def test_eta_closed_form() -> None:
    assert progress.eta_from_walls(10, 4, 12.0, 3, 2) == pytest.approx(12.0 / 3 * 6 / 2)
    assert progress.eta_from_walls(10, 4, 0.0, 0, 2) is None
    assert progress.eta_from_walls(10, 10, 5.0, 10, 2) == 0.0


def test_a_long_run_says_its_steps_and_an_estimate_and_a_short_one_nothing() -> None:
    """A run estimated at more than LONG_RUN_S (60 s at STEPS_PER_S) says so; one of exactly
    60 s, or less, says nothing (both sides of the boundary, no flight flown)."""
    at = int(progress.LONG_RUN_S * progress.STEPS_PER_S)
    assert at == 600_000
    assert progress.long_run_notice("x", at) is None
    assert progress.long_run_notice("x", 8176) is None
    assert progress.long_run_notice("x", at + 1) == (
        "x: 600,001 steps, about 1 min (an estimate at 10,000 steps a second); "
        "no progress bar off a terminal"
    )
    # the 100,000 periods of 511 steps
    assert progress.long_run_notice("big", 51_100_000).startswith(
        "big: 51,100,000 steps, about 1 h 25 min (an estimate at 10,000 steps a second)"
    )
    assert progress.long_run_notice("x", 100, steps_per_s=1.0).startswith(
        "x: 100 steps, about 2 min"
    )


@pytest.mark.jsbsim
@pytest.mark.parametrize(("rate", "said"), [(4088 / 60, False), (4088 / 60.1, True)])
def test_probing_run_off_a_terminal_says_it_is_long_before_it_starts(
    tmp_path, monkeypatch: pytest.MonkeyPatch, capsys, rate: float, said: bool
) -> None:
    """``probing run`` off a terminal (stderr captured: no bar) of a run estimated at more
    than a minute says so on stderr before the flight; at a minute it says nothing.  The
    baseline's 4088 steps stand in for a long run by a slower rate."""
    from pathlib import Path

    from probing.cli import main

    monkeypatch.setattr(progress, "STEPS_PER_S", rate)
    scenario = Path(__file__).resolve().parents[2] / "scenarios" / "baseline-737.toml"
    assert main(["run", str(scenario), "--out", str(tmp_path)]) == 0
    err = capsys.readouterr().err.splitlines()
    note = "probing: note: baseline-737: 4,088 steps, about 1 min (an estimate at 68 steps"
    assert err == ([f"{note} a second); no progress bar off a terminal"] if said else []), err
