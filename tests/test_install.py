"""The package as a user installs it: the wheel ships the GTM, the example scenarios and the
examples of the docs (examples/), and
(slow) installed into a fresh virtual environment it runs the GTM and a stock aircraft from a
folder outside the repository."""

from __future__ import annotations

import json
import os
import shutil
import subprocess
import sys
import tomllib
import zipfile
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
VERSION = tomllib.loads((ROOT / "pyproject.toml").read_text())["project"]["version"]
#: What a wheel is built from (the rest of the repository is not the package's).
SOURCES = ("pyproject.toml", "README.md", "LICENSE", "probing", "aircraft", "scenarios")
SOURCES += ("examples",)
#: Messages of pip that say no package index could be reached.
OFFLINE = ("NewConnectionError", "Temporary failure in name resolution", "No matching distribution")


def shipped(folder: str) -> list[str]:
    """The files of the repository's ``folder`` (``aircraft``, ``scenarios``, ``examples``), as
    the wheel names them."""
    base = ROOT / folder
    return sorted(
        f"probing/data/{folder}/{p.relative_to(base).as_posix()}"
        for p in base.rglob("*")
        if p.is_file() and "__pycache__" not in p.parts
    )


def build_wheel(tmp: Path) -> Path:
    """Build the wheel from a copy of the sources (the repository keeps no build/ folder)."""
    if subprocess.run([sys.executable, "-c", "import setuptools"]).returncode != 0:
        pytest.skip("setuptools is not installed here: no wheel can be built offline")
    src = tmp / "src"
    src.mkdir()
    for name in SOURCES:
        path = ROOT / name
        if path.is_dir():
            ignore = shutil.ignore_patterns("__pycache__", "*.egg-info")
            shutil.copytree(path, src / name, symlinks=True, ignore=ignore)
        else:
            shutil.copy(path, src / name)
    command = [sys.executable, "-m", "pip", "wheel", "--no-deps", "--no-build-isolation"]
    res = subprocess.run(
        [*command, "-q", "-w", str(tmp / "wheel"), str(src)], capture_output=True, text=True
    )
    assert res.returncode == 0, res.stderr
    (wheel,) = (tmp / "wheel").glob("probing-*.whl")
    return wheel


def test_the_wheel_ships_the_gtm_the_scenarios_and_the_examples(tmp_path: Path) -> None:
    wheel = build_wheel(tmp_path)
    assert wheel.name == f"probing-{VERSION}-py3-none-any.whl"
    names = set(zipfile.ZipFile(wheel).namelist())
    for required in ("probing/data/aircraft/gtm_t2/gtm_t2.xml", "probing/cli/examples.py"):
        assert required in names
    assert "probing/data/scenarios/fig4/a_deadband.toml" in names
    for doc_example in ("live/scenario.toml", "foreign-log/map.toml", "your-data/make_csv.py"):
        assert f"probing/data/examples/{doc_example}" in names
    for folder in ("aircraft", "scenarios", "examples"):
        missing = [n for n in shipped(folder) if n not in names]
        assert missing == [], missing
    assert not [n for n in names if "__pycache__" in n or n.endswith(".pyc")]
    # one top-level package, the project's own: no "analysis" to shadow a user's analysis.py
    assert {n.split("/")[0] for n in names if ".dist-info" not in n} == {"probing"}
    assert "probing/analysis/fig4.py" in names
    assert "probing/py.typed" in names and "probing/api/flight.py" in names
    assert "probing/data/examples/notebooks/quickstart.ipynb" in names


def short(path: Path, periods: int = 3) -> None:
    """Shorten a scenario file to ``periods`` probe periods (one settling)."""
    text = path.read_text()
    lines = [
        f"periods = {periods}"
        if line.startswith("periods =")
        else "settle_periods = 1"
        if line.startswith("settle_periods =")
        else line
        for line in text.splitlines()
    ]
    path.write_text("\n".join(lines) + "\n")


@pytest.mark.slow
@pytest.mark.jsbsim
def test_installed_in_a_fresh_venv_it_runs_outside_the_repository(tmp_path: Path) -> None:
    wheel = build_wheel(tmp_path)
    venv = tmp_path / "venv"
    subprocess.run([sys.executable, "-m", "venv", str(venv)], check=True)
    pip = [str(venv / "bin" / "python"), "-m", "pip", "install", "-q"]
    res = subprocess.run(
        [*pip, "-c", str(ROOT / "requirements.lock"), str(wheel)], capture_output=True, text=True
    )
    if res.returncode != 0 and any(m in res.stderr for m in OFFLINE):
        pytest.skip(f"pip cannot reach a package index: {res.stderr.strip().splitlines()[-1]}")
    assert res.returncode == 0, res.stderr
    outside = tmp_path / "elsewhere"
    outside.mkdir()
    env = {k: v for k, v in os.environ.items() if k not in ("PYTHONPATH", "VIRTUAL_ENV")}
    env["PROBING_CACHE"] = str(tmp_path / "cache")
    env.pop("PROBING_TWIN_CACHE", None)

    def probing(*args: str) -> str:
        res = subprocess.run(
            [str(venv / "bin" / "probing"), *args],
            capture_output=True,
            text=True,
            cwd=outside,
            env=env,
            timeout=600,
        )
        assert res.returncode == 0, (args, res.stderr)
        return res.stdout

    assert probing("--version").strip() == f"probing {VERSION}"
    assert str(venv) in probing("examples").splitlines()[0]  # the installed copy, not ROOT
    probing("examples", "--copy", "copied")  # copied/scenarios and copied/examples
    assert (outside / "copied" / "examples" / "your-data" / "probe_response.csv").is_file()
    short(outside / "copied" / "scenarios" / "fig4" / "a_deadband.toml")
    short(outside / "copied" / "scenarios" / "baseline-737.toml")
    probing("run", "copied/scenarios/fig4/a_deadband.toml", "--out", "results")  # the GTM
    probing("run", "copied/scenarios/baseline-737.toml", "--out", "results", "--truth")
    for run in ("fig4-a-deadband", "baseline-737"):
        assert (outside / "results" / run / "probing.parquet").is_file()
    info = probing("cache", "info")
    assert str(tmp_path / "cache") in info

    # the Python API, from the installed package: a shipped example, and the copied scenario
    # flown and saved byte for byte as `probing run` saved it
    script = (
        "import json, probing\n"
        "example = probing.example_path('fig4/a_deadband')\n"
        "flight = probing.fly(probing.load('copied/scenarios/fig4/a_deadband.toml'))\n"
        "folder = flight.save('api')\n"
        "back = probing.read(folder)\n"
        "print(json.dumps({'example': str(example), 'files': list(flight.files),\n"
        "    'equal': bool(back.bounds.equals(flight.bounds)),\n"
        "    'units': flight.bounds.attrs['units']['h_est'], 'all': sorted(probing.__all__)}))\n"
    )
    res = subprocess.run(
        [str(venv / "bin" / "python"), "-c", script],
        capture_output=True,
        text=True,
        cwd=outside,
        env=env,
        timeout=600,
    )
    assert res.returncode == 0, res.stderr
    got = json.loads(res.stdout.splitlines()[-1])
    assert got["example"].startswith(str(venv)) and got["equal"]
    assert got["units"] == {"theta_rad": "rad/deg", "q_rad_s": "rad/s/deg"}
    assert {"fly", "load", "read", "Flight", "Probe"} <= set(got["all"])
    for name in got["files"]:
        cli_file = outside / "results" / "fig4-a-deadband" / name
        assert (outside / "api" / "fig4-a-deadband" / name).read_bytes() == cli_file.read_bytes()
    site = next(venv.glob("lib/python*/site-packages/probing"))
    assert (site / "py.typed").is_file()
