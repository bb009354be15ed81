"""The command line as a new user meets it: one clear line and exit code 2 for bad input,
nothing written, nothing of JSBSim's on stdout, help that reads as plain text.

Each test here stands for a defect found by trying the project from a fresh clone.
"""

from __future__ import annotations

import json
import math
import os
import re
import shlex
import signal
import socket
import subprocess
import sys
import tomllib
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from probing.cli import build_parser
from probing.cli import main as cli_main

ROOT = Path(__file__).resolve().parents[2]
BASELINE = ROOT / "scenarios" / "baseline-737.toml"
SMALL_SWEEP = ROOT / "tests" / "data" / "sweeps" / "backlash-small.toml"


def probing(*args: str, cwd: Path = ROOT, timeout: float = 180) -> subprocess.CompletedProcess:
    """``python -m probing ARGS`` in a fresh process (real stdout and stderr)."""
    return subprocess.run(
        [sys.executable, "-m", "probing", *args],
        capture_output=True,
        text=True,
        cwd=cwd,
        timeout=timeout,
        env={**os.environ, "PYTHONPATH": str(ROOT)},
    )


def assert_one_line_error(res: subprocess.CompletedProcess, code: int, *needles: str) -> str:
    assert "Traceback" not in res.stderr, res.stderr
    assert res.returncode == code, (res.returncode, res.stderr)
    lines = res.stderr.splitlines()
    assert len(lines) == 1, res.stderr
    assert lines[0].startswith("probing: error: "), lines[0]
    for needle in needles:
        assert needle in lines[0], (needle, lines[0])
    return lines[0]


def unwritable(tmp_path: Path) -> Path:
    """A folder nothing can be created in, whoever runs the tests (root writes anywhere
    except in /proc)."""
    if os.geteuid() == 0:
        return Path("/proc/probing-test-out")
    locked = tmp_path / "locked"
    locked.mkdir()
    locked.chmod(0o500)
    return locked / "out"


def tree(path: Path) -> list[str]:
    return sorted(str(p.relative_to(path)) for p in path.rglob("*"))


# ------------------------------------------------------------------ 1. output folders
def test_run_out_a_file_is_one_line_exit_2_and_the_file_is_untouched(tmp_path: Path) -> None:
    target = tmp_path / "notes.txt"
    target.write_text("mine")
    res = probing("run", str(BASELINE), "--out", str(target))
    assert_one_line_error(res, 2, "--out", str(target), "is a file")
    assert res.stdout == "" and target.read_text() == "mine"
    assert tree(tmp_path) == ["notes.txt"]


def test_run_out_below_a_file_and_unwritable(tmp_path: Path) -> None:
    (tmp_path / "f").write_text("")
    res = probing("run", str(BASELINE), "--out", str(tmp_path / "f" / "sub"))
    assert_one_line_error(res, 2, "--out", "below a file")
    res = probing("run", str(BASELINE), "--out", str(unwritable(tmp_path)))
    assert_one_line_error(res, 2, "--out", "cannot write")
    assert tree(tmp_path) in (["f"], ["f", "locked"])


@pytest.mark.parametrize(
    "args",
    [
        ["truth", str(BASELINE), "--out", "{file}"],
        ["sweep", str(SMALL_SWEEP), "--out", "{file}"],
        ["sweep", str(SMALL_SWEEP), "--out", "{dir}/o", "--plot", "--figures", "{file}"],
        ["fig4", "--out", "{file}"],
        ["fig4", "--out", "{dir}/o", "--figures", "{file}"],
        ["fig4", "--out", "{dir}/o", "--copy-summary", "{file}/summary.md"],
        ["plot", "sweep", "{dir}", "--figures", "{file}"],
        ["modes", "--figure", "{file}/gtm_modes"],
    ],
    ids=lambda a: " ".join(a[:1] + [x for x in a if x.startswith("--")]),
)
def test_every_output_option_refuses_a_file(
    args: list[str], tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    target = tmp_path / "taken"
    target.write_text("mine")
    argv = [a.format(file=target, dir=tmp_path) for a in args]
    assert cli_main(argv) == 2
    out, err = capsys.readouterr()
    assert err.count("\n") == 1 and err.startswith("probing: error: --"), err
    assert "is a file" in err or "below a file" in err
    assert out == ""
    assert tree(tmp_path) == ["taken"] and target.read_text() == "mine"


def test_fig4_with_a_missing_scenario_folder(tmp_path: Path) -> None:
    res = probing("fig4", "--scenarios", str(tmp_path / "nowhere"), "--out", str(tmp_path / "o"))
    assert_one_line_error(res, 2, str(tmp_path / "nowhere"), "--scenarios")
    assert res.stdout == "" and tree(tmp_path) == []


def test_fig4_with_an_incomplete_scenario_folder(tmp_path: Path) -> None:
    (tmp_path / "set").mkdir()
    (tmp_path / "set" / "baseline.toml").write_text(BASELINE.read_text())
    res = probing("fig4", "--scenarios", str(tmp_path / "set"), "--out", str(tmp_path / "o"))
    assert_one_line_error(res, 2, "a_deadband.toml")
    assert tree(tmp_path) == ["set", "set/baseline.toml"]


def test_plot_fig4_of_a_missing_folder_says_so_on_stderr(tmp_path: Path) -> None:
    res = probing("plot", "fig4", str(tmp_path / "nothing"), "--figures", str(tmp_path / "f"))
    assert_one_line_error(res, 2, "not a results folder of probing fig4")
    assert res.stdout == "" and tree(tmp_path) == []


# ------------------------------------------------------------------ 2. Dask scheduler
def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def test_unreachable_scheduler_is_one_line_exit_2_and_writes_nothing(tmp_path: Path) -> None:
    address = f"tcp://127.0.0.1:{_free_port()}"
    res = probing(
        "sweep", str(SMALL_SWEEP), "--out", str(tmp_path / "out"), "--executor", "dask",
        "--scheduler", address, "--connect-timeout-s", "1",
    )  # fmt: skip
    assert_one_line_error(res, 2, "--scheduler", address, "no Dask scheduler answered")
    assert res.stdout == ""
    assert not (tmp_path / "out").exists()  # no lock, no points/, no sweep.json


def test_a_bad_scheduler_address_is_one_line_exit_2(tmp_path: Path) -> None:
    res = probing(
        "sweep", str(SMALL_SWEEP), "--out", str(tmp_path / "out"), "--executor", "dask",
        "--scheduler", "nonsense://", "--connect-timeout-s", "1",
    )  # fmt: skip
    assert_one_line_error(res, 2, "--scheduler")
    assert not (tmp_path / "out").exists()


# ------------------------------------------------------------------ 3. JSBSim's chatter
@pytest.mark.jsbsim
def test_trim_failure_shows_our_message_with_jsbsim_reason_and_nothing_on_stdout(
    tmp_path: Path,
) -> None:
    """At 180 KCAS the 737 cannot be trimmed clean; JSBSim says why ("Sorry, wdot doesn't
    appear to be trimmable"), which used to go to stdout."""
    scn = tmp_path / "slow.toml"
    scn.write_text(BASELINE.read_text().replace("speed_kcas = 280", "speed_kcas = 180"))
    res = probing("run", str(scn), "--out", str(tmp_path / "out"))
    assert res.stdout == ""
    assert_one_line_error(res, 1, "trim failed for 737", "speed_kcas = 180", "wdot")
    assert not (tmp_path / "out").exists()
    res = probing("design", "--aircraft", "737", "--altitude-ft", "15000", "--speed-kcas", "180")
    assert res.stdout == ""
    assert_one_line_error(res, 1, "trim failed for 737", "wdot")


# ------------------------------------------------------------------ 4. figures stay under --out
@pytest.mark.jsbsim
def test_sweep_plot_draws_under_its_output_folder(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    monkeypatch.chdir(tmp_path)  # a figures/ relative to where the user stands must not appear
    out = tmp_path / "elsewhere"
    assert cli_main(["sweep", str(SMALL_SWEEP), "--out", str(out), "-j", "1", "--plot"]) == 0
    printed = [line for line in capsys.readouterr().out.splitlines() if line.startswith("wrote")]
    figures = out / "backlash-small" / "figures"
    assert printed == [f"wrote {figures / 'sweep_backlash-small'}.{ext}" for ext in ("png", "pdf")]
    assert not (tmp_path / "figures").exists()


# ------------------------------------------------------------------ 5. committed figures
def test_committed_pdfs_carry_no_creation_date() -> None:
    """A date makes every redraw differ from the committed file (git status not clean)."""
    pdfs = sorted((ROOT / "figures").glob("*.pdf"))
    assert pdfs
    for pdf in pdfs:
        assert b"/CreationDate" not in pdf.read_bytes(), pdf.name


# ------------------------------------------------------------------ 7. design validation
DESIGN = {"--aircraft": ["737"], "--altitude-ft": ["15000"], "--speed-kcas": ["280"]}


@pytest.mark.parametrize(
    ("option", "values"),
    [
        ("--altitude-ft", ["-5"]),
        ("--altitude-ft", ["0"]),
        ("--speed-kcas", ["nan"]),
        ("--amplitude-deg", ["0"]),
        ("--noise-sigma", ["-1"]),
        ("--dt-s", ["0.5"]),
        ("--aircraft", ["no-such-plane"]),
        ("--deadband-deg", ["0.1", "0.2"]),
        ("--saturation-deg", ["2", "1"]),
        ("--rate-limit-deg-s", ["0"]),
        ("--target-gain-se", ["-1"]),
        ("--detect-gain-change", ["0"]),
        ("--false-alarm", ["1.5"]),
        ("--settle-periods", ["-1"]),
        ("--deadband-margin", ["nan"]),
    ],
    ids=lambda v: " ".join(v) if isinstance(v, list) else v,
)
def test_design_validates_as_the_scenario_schema_does(
    option: str, values: list[str], capsys: pytest.CaptureFixture[str]
) -> None:
    """Refused before anything is trimmed, naming the option."""
    flags = {**DESIGN, option: values}
    argv = ["design", *[x for flag, vals in flags.items() for x in (flag, *vals)]]
    assert cli_main(argv) == 2
    out, err = capsys.readouterr()
    assert out == ""
    assert err.count("\n") == 1 and err.startswith(f"probing: error: {option}: "), err


@pytest.mark.jsbsim
def test_design_refuses_more_periods_than_a_scenario_holds(
    capsys: pytest.CaptureFixture[str],
) -> None:
    argv = ["design", "--aircraft", "737", "--altitude-ft", "15000", "--speed-kcas", "280"]
    assert cli_main([*argv, "--noise-sigma", "1e-3", "--target-h-se", "1e-9"]) == 2
    out, err = capsys.readouterr()
    assert out == ""
    assert err.count("\n") == 1 and "out of reach" in err and "99998" in err


# ------------------------------------------------------------------ 8. sweep progress
@pytest.mark.jsbsim
def test_sweep_reports_each_point_on_stderr(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    assert cli_main(["sweep", str(SMALL_SWEEP), "--out", str(tmp_path), "-j", "2"]) == 0
    err = capsys.readouterr().err.splitlines()
    assert err[0] == "backlash-small: 7 runs to do"
    progress = err[1:]
    assert len(progress) == 7  # 6 points and the shared reference, one line each
    for k, line in enumerate(progress, start=1):
        assert line.startswith(f"backlash-small: {k}/7 runs, 0 failed")
        assert " done in " in line
    assert all("ETA" in line for line in progress[:-1])
    assert cli_main(["sweep", str(SMALL_SWEEP), "--out", str(tmp_path)]) == 0
    assert capsys.readouterr().err.splitlines() == [
        "backlash-small: 0 runs to do; 6 points already done, 0 recorded as failed"
    ]


def test_progress_comes_from_tqdm() -> None:
    import probing.experiment.output.progress as progress

    assert progress.tqdm.__module__.startswith("tqdm")
    assert not (ROOT / "probing" / "progress.py").exists()


# ------------------------------------------------------------------ 9. help and docs
def test_help_is_plain_text_and_states_defaults() -> None:
    parser = build_parser()
    top = parser.format_help()
    assert "``" not in top and ":mod:" not in top
    for command in ("run", "truth", "sweep", "fig4", "plot", "design", "modes"):
        assert command in top
    subs = parser._subparsers._group_actions[0].choices
    run_help = subs["run"].format_help()
    assert "(default: results)" in run_help
    truth_help = subs["truth"].format_help()
    assert "scenario TOML file" in truth_help and "(default: results)" in truth_help
    for name, sub in subs.items():
        for action in sub._actions:
            if action.dest != "help":
                assert action.help, f"probing {name} {action.dest} has no help"


def test_docs_do_not_point_outside_the_repository() -> None:
    for page in [ROOT / "README.md", *sorted((ROOT / "docs").glob("*.md"))]:
        text = page.read_text(encoding="utf-8")
        assert "../shared" not in text and "NOTES.md" not in text, page.name
    assert "## Errata" in (ROOT / "docs" / "method.md").read_text(encoding="utf-8")


def test_every_summary_column_is_documented() -> None:
    from probing.sweep.summary import SUMMARY_COLUMNS

    text = (ROOT / "docs" / "sweeps.md").read_text(encoding="utf-8")
    for column in SUMMARY_COLUMNS:
        assert f"`{column}`" in text, column


def test_example_says_how_to_run_it() -> None:
    text = (ROOT / "scenarios" / "examples" / "build_and_run.py").read_text()
    assert ".venv/bin/python scenarios/examples/build_and_run.py" in text


# ------------------------------------------------------------------ 11. set-up noise
def test_license_is_an_spdx_expression() -> None:
    """A table license makes setuptools print a deprecation banner during make setup."""
    project = tomllib.loads((ROOT / "pyproject.toml").read_text())["project"]
    assert project["license"] == "MIT"
    build = tomllib.loads((ROOT / "pyproject.toml").read_text())["build-system"]
    assert any(r.startswith("setuptools>=77") for r in build["requires"])


# ------------------------------------------------------------------ 12. refused before any work
MONITORED = ROOT / "scenarios" / "monitor" / "base.toml"  # name gtm-monitored, has [monitor]


@pytest.fixture
def no_work(monkeypatch: pytest.MonkeyPatch) -> None:
    """Every command's work fails the test: a refusal must come before any of it."""
    import probing.analysis.fig4
    import probing.experiment.design.design
    import probing.experiment.flight.monitor
    import probing.experiment.flight.run
    import probing.experiment.studies.fig4
    import probing.experiment.studies.gtm_damage
    import probing.experiment.studies.modes
    import probing.experiment.studies.truth
    import probing.sweep

    def work(*args: object, **kwargs: object) -> None:
        raise AssertionError("work started before the output paths were checked")

    for module, name in [
        (probing.experiment.flight.run, "run_scenario"),
        (probing.experiment.design.design, "recommend"),
        (probing.experiment.studies.truth, "compute_truth"),
        (probing.experiment.flight.monitor, "monitor_scenario"),
        (probing.experiment.studies.fig4, "run_set"),
        (probing.experiment.studies.modes, "mode_table"),
        (probing.experiment.studies.gtm_damage, "run_example6"),
        (probing.sweep, "run_sweep"),
        (probing.analysis.fig4, "collect"),
    ]:
        monkeypatch.setattr(module, name, work)


def refused(argv: list[str], root: Path, capsys: pytest.CaptureFixture[str], *needles: str) -> str:
    """``probing ARGV`` in this process: exit 2, one line on stderr naming ``needles``,
    nothing on stdout, nothing created, changed or removed under ``root``."""
    before = {p: (p.stat().st_mtime_ns if p.is_file() else None) for p in root.rglob("*")}
    assert cli_main(argv) == 2
    out, err = capsys.readouterr()
    assert out == ""
    assert err.count("\n") == 1 and err.startswith("probing: error: "), err
    for needle in needles:
        assert needle in err, (needle, err)
    assert {p: (p.stat().st_mtime_ns if p.is_file() else None) for p in root.rglob("*")} == before
    return err


def test_a_corrupt_stored_run_is_one_line_naming_the_file(tmp_path: Path) -> None:
    """A probing.parquet of garbage bytes: ``plot fig4`` and ``fig4`` (which would reuse the
    stored run) say which file cannot be read; nothing is simulated or drawn."""
    results = tmp_path / "results"
    run = results / "fig4-baseline"
    run.mkdir(parents=True)
    for name in ("probing.parquet", "timeseries.parquet"):
        (run / name).write_bytes(b"not a parquet file at all" * 10)
    panels = {"baseline": "fig4-baseline", **{k: "fig4-baseline" for k in ("a_deadband",)}}
    (results / "manifest.json").write_text(json.dumps({"set": "fig4", "panels": panels}))
    before = tree(tmp_path)
    figures = str(tmp_path / "figures")
    res = probing("plot", "fig4", str(results), "--figures", figures)
    assert_one_line_error(res, 2, str(run / "probing.parquet"))
    assert res.stdout == "" and tree(tmp_path) == before
    res = probing("fig4", "--out", str(results), "--figures", figures, timeout=60)
    assert_one_line_error(res, 2, str(run / "probing.parquet"), "--force")
    assert res.stdout == "" and tree(tmp_path) == before


@pytest.mark.parametrize(
    ("argv", "name"),
    [
        (["run", str(BASELINE)], "baseline-737"),
        (["truth", str(BASELINE)], "baseline-737"),
        (["monitor", str(MONITORED)], "gtm-monitored"),
        (["sweep", str(SMALL_SWEEP)], "backlash-small"),
    ],
    ids=lambda v: v[0] if isinstance(v, list) else None,
)
def test_out_whose_run_folder_is_a_file(
    argv: list[str], name: str, tmp_path: Path, capsys: pytest.CaptureFixture[str], no_work: None
) -> None:
    (tmp_path / name).write_text("mine")
    refused([*argv, "--out", str(tmp_path)], tmp_path, capsys, str(tmp_path / name), "is a file")
    assert (tmp_path / name).read_text() == "mine"


def test_run_out_whose_run_folder_is_a_file_in_a_fresh_process(tmp_path: Path) -> None:
    (tmp_path / "baseline-737").write_text("mine")
    res = probing("run", str(BASELINE), "--out", str(tmp_path))
    assert_one_line_error(res, 2, "--out", str(tmp_path / "baseline-737"), "is a file")
    assert res.stdout == "" and tree(tmp_path) == ["baseline-737"]


OUTPUT_FILES = [
    ["fig4", "--out", "{dir}/o", "--copy-summary", "{target}"],
    ["plot", "fig4", "{dir}/r", "--copy-summary", "{target}"],
    ["plot", "monitor", "{dir}/r", "--summary", "{target}"],
    ["plot", "references", "{dir}/r", "--summary", "{target}"],
    ["plot", "simultaneous", "{dir}/r", "--summary", "{target}"],
    ["plot", "manoeuvres", "{dir}/r", "--summary", "{target}"],
    ["modes", "--docs", "{target}", "--figure", "{dir}/f/gtm_modes"],
    ["modes", "--figure", "{target}", "--docs", "{dir}/d/gtm.md"],
    [
        "design",
        "--aircraft",
        "737",
        "--altitude-ft",
        "15000",
        "--speed-kcas",
        "280",
        "--save-scenario",
        "{target}",
    ],
    [
        "design",
        "--aircraft",
        "737",
        "--altitude-ft",
        "15000",
        "--speed-kcas",
        "280",
        "--export-probe",
        "{target}",
    ],
]
OUTPUT_FOLDERS = [
    ["run", str(BASELINE), "--out", "{target}"],
    ["truth", str(BASELINE), "--out", "{target}"],
    ["monitor", str(MONITORED), "--out", "{target}"],
    ["sweep", str(SMALL_SWEEP), "--out", "{target}"],
    ["sweep", str(SMALL_SWEEP), "--out", "{dir}/o", "--plot", "--figures", "{target}"],
    ["fig4", "--out", "{target}"],
    ["fig4", "--out", "{dir}/o", "--figures", "{target}"],
    ["plot", "sweep", "{dir}/r", "--figures", "{target}"],
    ["plot", "monitor", "{dir}/r", "--figures", "{target}"],
    ["gtm-damage", "--out", "{target}", "--figures", "{dir}/f"],
    ["gtm-damage", "--out", "{dir}/o", "--figures", "{target}"],
]


def _ids(argv: list[str]) -> str:
    return " ".join(a for a in argv if not a.startswith(("{", str(ROOT))))


def _option(argv: list[str]) -> str:
    return argv[argv.index("{target}") - 1]


@pytest.mark.parametrize("argv", OUTPUT_FILES, ids=_ids)
def test_every_output_file_option_refuses_a_folder_below_a_file_and_unwritable(
    argv: list[str], tmp_path: Path, capsys: pytest.CaptureFixture[str], no_work: None
) -> None:
    (tmp_path / "r").mkdir()  # the stored results a plot reads
    option = _option(argv)
    folder = tmp_path / "a-folder"
    (folder / "gtm_modes.png").mkdir(parents=True)  # --figure is the name without .png
    target = folder / "gtm_modes" if option == "--figure" else folder
    cases = [
        (target, ("is a folder, not a file",)),
        (tmp_path / "a-file" / "summary.md", ("below a file",)),
        (unwritable(tmp_path) / "summary.md", ("cannot write",)),
    ]
    (tmp_path / "a-file").write_text("mine")
    for path, needles in cases:
        args = [a.format(dir=tmp_path, target=path) for a in argv]
        refused(args, tmp_path, capsys, f"{option} {path}", *needles)


@pytest.mark.parametrize("argv", OUTPUT_FOLDERS + OUTPUT_FILES, ids=_ids)
def test_every_output_path_option_refuses_an_empty_path(
    argv: list[str],
    tmp_path: Path,
    capsys: pytest.CaptureFixture[str],
    monkeypatch: pytest.MonkeyPatch,
    no_work: None,
) -> None:
    """``--out ""`` would be the current folder."""
    (tmp_path / "r").mkdir()
    monkeypatch.chdir(tmp_path)
    option = _option(argv)
    with pytest.raises(SystemExit) as exc:
        cli_main([a.format(dir=tmp_path, target="") for a in argv])
    assert exc.value.code == 2
    out, err = capsys.readouterr()
    assert out == "" and err == f"probing: error: argument {option}: empty path\n"
    assert tree(tmp_path) == ["r"]


@pytest.mark.parametrize(
    "argv",
    [["run", ""], ["sweep", ""], ["plot", "fig4", ""], ["design", "--simultaneous", ""]],
    ids=" ".join,
)
def test_an_empty_input_path_is_refused(
    argv: list[str], capsys: pytest.CaptureFixture[str]
) -> None:
    with pytest.raises(SystemExit) as exc:
        cli_main(argv)
    assert exc.value.code == 2
    out, err = capsys.readouterr()
    assert out == "" and err.count("\n") == 1 and err.endswith(": empty path\n"), err


# ------------------------------------------------------------------ 13. argparse in one line
@pytest.mark.parametrize(
    ("argv", "line"),
    [
        (
            ["design", "--altitude-ft", "abc"],
            "argument --altitude-ft: invalid float value: 'abc'",
        ),
        (["run"], "the following arguments are required: scenario"),
        ([], "the following arguments are required: command"),
        (["fly"], "argument command: invalid choice: 'fly'"),
        (["run", str(BASELINE), "--bogus"], "unrecognized arguments: --bogus"),
        (["plot", "nothing", "r"], "argument target: invalid choice: 'nothing'"),
        (["sweep", str(SMALL_SWEEP), "-j", "two"], "argument -j/--jobs: invalid int value"),
    ],
    ids=lambda v: " ".join(v) if isinstance(v, list) else None,
)
def test_argument_errors_are_one_line(argv: list[str], line: str) -> None:
    res = probing(*argv)
    assert_one_line_error(res, 2, line)
    assert res.stdout == ""


# ------------------------------------------------------------------ 14. help
def _subcommands() -> dict[str, Any]:
    return build_parser()._subparsers._group_actions[0].choices


def test_help_states_each_default_once_and_never_none() -> None:
    for name, sub in _subcommands().items():
        text = " ".join(sub.format_help().split())  # the wrapping may split "(default:"
        assert "(default: None)" not in text, name
        for line in text.split("--"):
            assert line.count("(default:") <= 1, (name, line)
    sweep = " ".join(_subcommands()["sweep"].format_help().split())
    assert "(default: one per core)" in sweep and "(default: OUT/<name>/figures)" in sweep
    design = " ".join(_subcommands()["design"].format_help().split())
    assert "(1 sigma) (default: 0.0)" in design  # a zero is stated, a flag's False is not
    assert "print one JSON object (default" not in design


def test_top_level_help_lists_every_command_once() -> None:
    text = build_parser().format_help()
    names = list(_subcommands())
    assert "gtm-damage" in names and "analyze" in names and "live" in names
    assert "excitations" in names
    assert len(names) == 14
    listed = [line.split()[0] for line in text.splitlines() if line.startswith("    ")]
    listed = [word for word in listed if word in names]
    assert listed == names, text
    for name in names:  # not a second, hand-written list
        assert len(re.findall(rf"^ +{re.escape(name)}\b", text, re.MULTILINE)) == 1, name
    flat = " ".join(text.split())
    assert "fig4 or a sweep" not in flat
    plot = flat[flat.index(" plot ") : flat.index(" design ")]
    for target in ("fig4", "sweep", "monitor", "simultaneous", "manoeuvre"):
        assert target in plot, plot


# ------------------------------------------------------------------ 15. strict JSON
def test_json_files_are_strict_json_with_null_for_nan(tmp_path: Path) -> None:
    from probing.experiment.output.storage import write_json_atomic

    def refuse(name: str) -> None:
        raise ValueError(f"not JSON: {name}")

    payload = {"a": math.nan, "b": [1.0, math.inf, -math.inf], "c": {"d": (np.float64("nan"),)}}
    for compact in (False, True):
        write_json_atomic(tmp_path / "x.json", payload, compact=compact)
        found = json.loads((tmp_path / "x.json").read_text(), parse_constant=refuse)
        assert found == {"a": None, "b": [1.0, None, None], "c": {"d": [None]}}


def test_a_sweep_points_record_with_nan_is_strict_json_and_reads_back(tmp_path: Path) -> None:
    """A monitor point that never alarmed (first_alarm_s, alpha NaN) and a prediction that
    is NaN: point.json holds null, and the summary reads them back as NaN."""
    from probing.experiment.output.storage import write_json_atomic
    from probing.sweep import load_sweep
    from probing.sweep.summary import summarise

    sweep_file = tmp_path / "mon.toml"
    sweep_file.write_text(
        f'name = "mon"\nbase = "{MONITORED}"\nkind = "monitor"\n[grid]\n"disturbance.seed" = [1]\n'
    )
    sweep = load_sweep(sweep_file)
    (point,) = sweep.points
    folder = tmp_path / "out" / "mon" / "points" / f"point_id={point.point_id}"
    facts = {
        "first_alarm_s": math.nan,
        "first_alarm_period": None,
        "verdict": "none",
        "alpha_per_period": math.nan,
        "ended": "",
    }
    info = {"wall_s": 1.0, "steps_simulated": 10, "monitor": facts, "predicted": math.nan}
    write_json_atomic(folder / "point.json", info, compact=True)
    text = (folder / "point.json").read_text()
    assert "NaN" not in text
    json.loads(text, parse_constant=lambda name: pytest.fail(f"bare {name}"))
    (row,) = summarise(sweep, tmp_path / "out" / "mon").itertuples()
    assert row.status == "done" and math.isnan(row.first_alarm_s)
    assert math.isnan(row.alpha_per_period)


@pytest.mark.parametrize(
    ("argv", "inside"),
    [
        (["fig4", "--out", "{dir}/o", "--figures", "{dir}/f"], "summary.md"),
        (["fig4", "--out", "{dir}/o", "--figures", "{dir}/f"], "summary.csv"),
        (["fig4", "--out", "{dir}/o", "--figures", "{dir}/f"], "manifest.json"),
        (["plot", "fig4", "{dir}/o", "--figures", "{dir}/f"], "summary.md"),
        (["gtm-damage", "--out", "{dir}/o", "--figures", "{dir}/f"], "summary.csv"),
    ],
    ids=lambda v: " ".join(v[:2]) if isinstance(v, list) else v,
)
def test_a_file_written_into_an_output_folder_that_is_a_folder(
    argv: list[str], inside: str, tmp_path: Path, capsys: pytest.CaptureFixture[str], no_work: None
) -> None:
    (tmp_path / "o" / inside).mkdir(parents=True)
    path = tmp_path / "o" / inside
    refused([a.format(dir=tmp_path) for a in argv], tmp_path, capsys, str(path), "is a folder")


def _importing_frame():
    """A frame as a signal handler sees it inside an import (where Python drops a raise)."""

    class Frame:
        f_code = type("Code", (), {"co_filename": "<frozen importlib._bootstrap>"})()
        f_back = None

    return Frame()


@pytest.mark.parametrize("then", ["breaks", "finishes"])
def test_a_ctrl_c_lost_where_it_landed_still_ends_the_command(
    then: str, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    """A Ctrl-C that landed where Python drops it (an import) and then broke the command
    (a pool's workers ended: another error), or let it finish: one line, exit 130."""
    import probing.cli as cli
    import probing.cli.plot as plot_command
    from probing.core.forked import INTERRUPTS

    def command(args):
        INTERRUPTS._handler(signal.SIGINT, _importing_frame())  # as the signal would
        if then == "breaks":
            raise RuntimeError("A child process terminated abruptly")
        return 0

    monkeypatch.setattr(plot_command, "_cmd_plot", command)  # the plot command
    assert cli.main(["plot", "fig4", "results"]) == 130
    out, err = capsys.readouterr()
    assert err == "probing: error: interrupted\n" and out == ""
    assert signal.getsignal(signal.SIGINT) is signal.default_int_handler  # put back


def test_an_error_without_a_ctrl_c_is_not_called_an_interrupt(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    """The same error with no Ctrl-C noted propagates as itself."""
    import probing.cli as cli
    import probing.cli.plot as plot_command

    def command(args):
        raise RuntimeError("a bug")

    monkeypatch.setattr(plot_command, "_cmd_plot", command)  # the plot command
    with pytest.raises(RuntimeError, match="a bug"):
        cli.main(["plot", "fig4", "results"])


# ------------------------------------------------------------------ 17. tables of the parser
def test_the_plot_targets_are_the_plot_commands_choices_and_help() -> None:
    """``probing plot``'s choices, help and top-level line come from PLOT_TARGETS alone."""
    from probing.cli.plot import PLOT_TARGETS

    plot = _subcommands()["plot"]
    (target,) = [a for a in plot._actions if a.dest == "target"]
    assert list(target.choices) == list(PLOT_TARGETS)
    text = " ".join(plot.format_help().split())
    top = " ".join(build_parser().format_help().split())
    for name, entry in PLOT_TARGETS.items():
        assert f"{name}: {entry.results}" in text, name
        assert entry.what in top, name
    figures = (
        "figures for fig4; RESULTS/figures for sweep, monitor, references, simultaneous, manoeuvres"
    )
    assert f"figure folder (default: {figures})" in text  # as the next test finds them
    assert (
        "monitor, references, simultaneous, manoeuvres: write the study's tables to this file "
        in text
    )
    assert "(default: RESULTS/summary.md)" in text


@pytest.mark.parametrize(
    "name", ["fig4", "sweep", "monitor", "references", "simultaneous", "manoeuvres"]
)
def test_each_plot_target_draws_into_its_stated_defaults(
    name: str, monkeypatch: pytest.MonkeyPatch, tmp_path: Path
) -> None:
    """The default figure folder and summary file a target is given are the ones its help
    states: figures for fig4, RESULTS/figures otherwise; RESULTS/summary.md for a study."""
    import dataclasses

    from probing.cli.plot import PLOT_TARGETS

    seen: list[Any] = []
    entry = dataclasses.replace(PLOT_TARGETS[name], draw=lambda args: seen.append(args) or 0)
    monkeypatch.setitem(PLOT_TARGETS, name, entry)
    assert cli_main(["plot", name, str(tmp_path)]) == 0
    (args,) = seen
    assert args.figures == (Path("figures") if name == "fig4" else tmp_path / "figures")
    study = name in ("monitor", "references", "simultaneous", "manoeuvres")
    assert args.summary == (tmp_path / "summary.md" if study else None)


def test_every_design_option_defaults_to_its_design_request_field() -> None:
    """A ``probing design`` option's default is its DesignRequest field's (None when the
    field is required), stated once in its help; no options give the default request."""
    import dataclasses

    import probing.cli.design as design_command
    from probing.experiment.design.design_request import DesignRequest

    design = _subcommands()["design"]
    actions = {a.dest: a for a in design._actions}
    formatter = design._get_formatter()
    for f in dataclasses.fields(DesignRequest):
        action = actions[f.name]
        assert action.option_strings == ["--" + f.name.replace("_", "-")]
        required = f.default is dataclasses.MISSING
        assert action.default == (None if required else f.default), f.name
        text = formatter._expand_help(action)
        switch = f.default is False  # a flag's False is not stated
        stated = None if required or f.default is None or switch else f"(default: {f.default})"
        if stated is not None:
            assert text.count("(default:") == 1 and stated in text, (f.name, text)
    condition = ["--aircraft", "737", "--altitude-ft", "15000", "--speed-kcas", "280"]
    args = build_parser().parse_args(["design", *condition])
    assert design_command._request(args) == DesignRequest("737", 15000.0, 280.0)


def test_every_design_option_reaches_the_request() -> None:
    """Each option given a value other than its default: the request holds every one."""
    import dataclasses

    import probing.cli.design as design_command
    from probing.experiment.design.design_request import DesignRequest

    given = DesignRequest(
        aircraft="gtm_t2",
        altitude_ft=800.0,
        speed_kcas=75.0,
        dt_s=0.02,
        deadband_deg=(-0.1, 0.2),
        saturation_deg=(-3.0, 4.0),
        rate_limit_deg_s=20.0,
        channel="q_rad_s",
        noise_sigma=1e-4,
        turbulence="light",
        calibration_seeds=8,
        estimator="cyclic",
        detect_gain_change=0.1,
        false_alarm=0.05,
        detection_probability=0.8,
        amplitude_deg=0.01,
        deadband_margin=2.0,
        settle_periods=3,
        drift="nominal",
        sensors="nasa_t2",
        closed_loop=True,
        window_periods=4,
        baseline_periods=20,
        false_alarms_per_hour=0.5,
    )

    def argv(request: DesignRequest) -> list[str]:
        out = ["design"]
        for name, value in vars(request).items():
            if value is True:  # a switch
                out.append("--" + name.replace("_", "-"))
            elif value is not None:
                values = value if isinstance(value, tuple) else (value,)
                out += ["--" + name.replace("_", "-"), *map(str, values)]
        return out

    for request in (
        given,
        dataclasses.replace(given, detect_gain_change=None, target_gain_se=0.01),  # one target
        dataclasses.replace(given, detect_gain_change=None, target_h_se=0.01),  # at a time
    ):
        assert design_command._request(build_parser().parse_args(argv(request))) == request


def test_bounds_is_an_option_of_fig4_and_plot_fig4(tmp_path: Path) -> None:
    """``--bounds`` parses for ``probing fig4`` and ``probing plot fig4``, off by default."""
    parser = build_parser()
    assert parser.parse_args(["fig4"]).bounds is False
    assert parser.parse_args(["fig4", "--bounds"]).bounds is True
    assert parser.parse_args(["plot", "fig4", str(tmp_path)]).bounds is False
    assert parser.parse_args(["plot", "fig4", str(tmp_path), "--bounds"]).bounds is True


@pytest.mark.parametrize("flag", [[], ["--bounds"]])
def test_plot_fig4_hands_bounds_to_the_figures(
    flag: list[str], tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """``probing plot fig4 RESULTS --bounds`` draws the figures with their bands; without it,
    without them.  Another plot target refuses ``--bounds`` (exit 2)."""
    from probing.analysis import fig4, fig4_plots

    class Data:
        set_name = "fig4"

    asked: list[bool] = []
    monkeypatch.setattr(fig4, "collect", lambda results: Data())
    monkeypatch.setattr(fig4, "write_summary", lambda data, results: "")
    monkeypatch.setattr(
        fig4_plots, "draw", lambda data, folder, stem, bounds=False: asked.append(bounds) or []
    )
    figures = str(tmp_path / "figures")
    assert cli_main(["plot", "fig4", str(tmp_path), "--figures", figures, *flag]) == 0
    assert asked == [flag == ["--bounds"]]
    if flag:
        assert cli_main(["plot", "sweep", str(tmp_path), *flag]) == 2


def test_a_sigterm_held_in_an_import_still_ends_the_command_with_143(
    monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    """A SIGTERM that lands in an import (pyarrow imports pandas at its first table) is held
    there and raised at the next check: one line, exit 143, not the import's RuntimeError."""
    import probing.cli as cli
    import probing.cli.plot as plot_command

    def command(args):
        try:
            cli._terminate(signal.SIGTERM, _importing_frame())  # as the signal would
        except KeyboardInterrupt as exc:  # what a class body's __set_name__ makes of it
            raise RuntimeError("Error calling __set_name__") from exc
        return 0

    monkeypatch.setattr(plot_command, "_cmd_plot", command)
    assert cli.main(["plot", "fig4", "results"]) == 143
    out, err = capsys.readouterr()
    assert err == "probing: error: terminated\n" and out == ""


# ------------------------------------------------------------------ 18. examples and files in help
def _examples(name: str) -> list[str]:
    """The example lines at the end of ``probing <name> --help``, their comments dropped."""
    text = _subcommands()[name].format_help()
    assert "\nexamples:\n" in text, name
    tail = text.split("\nexamples:\n", 1)[1]
    return [line.split("  # ")[0].strip() for line in tail.splitlines() if line.strip()]


def test_every_commands_help_ends_with_examples_that_parse() -> None:
    """No help text had an example.  Every command's help ends with at least one, each a
    command line of that command the parser takes as written (and the top-level help shows
    one too)."""
    assert "\nexamples:\n  probing run " in build_parser().format_help()
    for name in _subcommands():
        examples = _examples(name)
        assert examples, name
        for line in examples:
            words = shlex.split(line)
            assert words[:2] == ["probing", name], line
            assert build_parser().parse_args(words[1:]).command == name, line


def _named_files(text: str) -> list[str]:
    """The run-folder files (the registry's names) a help text names, in its order."""
    from probing.experiment.output.layouts import OUTPUT_FILES

    flat = " ".join(text.split())
    return sorted((n for n in OUTPUT_FILES if n in flat), key=flat.index)


@pytest.fixture(scope="module")
def flown(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """``probing run --truth`` of a small 737 scenario, ``probing monitor`` of the tests'
    short monitored GTM flight and ``probing analyze`` of the example record, into one
    folder: ``run/``, ``monitor/``, ``analyze/``."""
    base = tmp_path_factory.mktemp("flown")
    scenario = base / "small.toml"
    scenario.write_text(
        BASELINE.read_text()
        .replace("order = 9", "order = 5")
        .replace("periods = 8", "periods = 3")
        .replace("settle_periods = 2", "settle_periods = 1")
    )
    assert cli_main(["run", str(scenario), "--out", str(base / "run"), "--truth"]) == 0
    monitored = ROOT / "tests" / "data" / "sweeps" / "base-gtm-monitor.toml"
    assert cli_main(["monitor", str(monitored), "--out", str(base / "monitor")]) == 0
    record = ROOT / "examples" / "your-data" / "probe_response.csv"
    analyze = ["--time", "time_s", "--input", "elevator_deg", "--output", "q_rad_s"]
    analyze += ["--order", "7", "--bit-duration-s", "0.04", "--out", str(base / "analyze")]
    assert cli_main(["analyze", str(record), *analyze]) == 0
    return base


def test_the_files_each_help_names_are_the_files_the_command_writes(flown: Path) -> None:
    """``probing --help`` said ``run`` writes probing.parquet and timeseries.parquet (it
    writes bounds.parquet too).  The files each command's help names are
    :data:`~probing.experiment.output.layouts.FLIGHT_FILES`' (``run``'s line; ``--truth``'s
    help: the truth's), and those are exactly the files it wrote."""
    from probing.experiment.output.layouts import FLIGHT_FILES

    subs = _subcommands()
    top = build_parser().format_help()
    run_line = top[top.index("    run ") : top.index("    truth ")]
    (truth_option,) = [a for a in subs["run"]._actions if a.dest == "truth"]
    assert _named_files(run_line) == list(FLIGHT_FILES["run"])
    assert _named_files(subs["run"].description) == list(FLIGHT_FILES["run"])
    assert _named_files(truth_option.help) == list(FLIGHT_FILES["truth"])
    assert _named_files(subs["monitor"].description) == list(FLIGHT_FILES["monitor"])
    assert _named_files(subs["analyze"].description) == list(FLIGHT_FILES["analyze"])

    def written(folder: Path) -> list[str]:
        return sorted(p.name for p in folder.iterdir() if p.suffix == ".parquet")

    (run,) = (flown / "run").iterdir()
    assert written(run) == sorted(FLIGHT_FILES["run"] + FLIGHT_FILES["truth"])
    (monitored,) = (flown / "monitor").iterdir()
    assert written(monitored) == sorted(FLIGHT_FILES["monitor"])
    assert written(flown / "analyze") == sorted(FLIGHT_FILES["analyze"])


def _committed(path: Path) -> bool:
    """Whether ``path`` (relative to the repository) is in the committed docs/ or figures/."""
    return path.parts[:1] in (("docs",), ("figures",))


def test_no_command_but_fig4_writes_committed_docs_or_figures_by_default(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """``probing modes`` rewrote docs/gtm.md and figures/gtm_modes.png, ``excitations``
    docs/excitations_summary.md and figures/, ``gtm-damage`` figures/, when run bare: they
    write into their results folder unless the committed paths are named (the Makefile
    names them).  fig4 draws the paper's figure into figures/ as make fig4 does."""
    import probing.cli.excitations
    import probing.cli.gtm

    for name, sub in _subcommands().items():
        for action in sub._actions:
            if isinstance(action.default, Path) and name != "fig4":
                assert not _committed(action.default), (name, action.dest, action.default)
    makefile = (ROOT / "Makefile").read_text()
    assert "probing modes --docs docs/gtm.md --figure figures/gtm_modes" in makefile
    assert "--figures figures --summary docs/excitations_summary.md" in makefile
    assert "probing gtm-damage --figures figures" in makefile
    for module in (probing.cli.excitations, probing.cli.gtm):
        monkeypatch.setattr(module, "simulating", lambda job, where: 0)
    out = tmp_path / "o"
    for argv, outputs in [
        (["excitations", "--out", str(out)], ("figures", "summary")),
        (["gtm-damage", "--out", str(out)], ("figures",)),
    ]:
        args = build_parser().parse_args(argv)
        assert args.func(args) == 0
        for dest in outputs:
            assert Path(getattr(args, dest)).is_relative_to(out), (argv, dest)
    assert not out.exists()
