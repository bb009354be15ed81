"""The environment the suite runs in is the pinned one (requirements.lock, make setup)."""

from __future__ import annotations

import os
import re
import subprocess
from pathlib import Path

from conftest import LOCK, installed_version, locked_versions

ROOT = Path(__file__).resolve().parents[1]


def test_every_locked_package_is_installed_at_its_pinned_version() -> None:
    """make setup installs requirements.lock exactly: a drifted package fails here."""
    off = {
        name: (installed_version(name), version)
        for name, version in locked_versions().items()
        if installed_version(name) != version
    }
    assert not off, f"installed vs pinned: {off}"


def test_the_lock_pins_every_declared_dependency() -> None:
    """Each dependency pyproject.toml declares (runtime and dev) has a line in the lock."""
    import tomllib

    project = tomllib.loads((ROOT / "pyproject.toml").read_text())["project"]
    declared = project["dependencies"] + project["optional-dependencies"]["dev"]
    names = {re.sub(r"[-_.]+", "-", re.split(r"[\[<>=!~ ]", d)[0]).lower() for d in declared}
    names |= {"pip", "setuptools", "wheel"}  # make setup installs and builds with these
    assert names <= set(locked_versions()), names - set(locked_versions())
    assert all(re.fullmatch(r"[0-9][0-9A-Za-z.]*", v) for v in locked_versions().values())


def test_the_notebook_front_end_is_pinned_apart_and_only_make_notebook_installs_it() -> None:
    """No Jupyter front end could open the notebook.  The ``notebook`` extra is pinned,
    exactly, in requirements-notebook.lock, none of whose packages requirements.lock pins
    (it constrains them instead); make notebook installs it with that constraint and opens
    the quickstart, and make setup (so make test) does not install it."""
    import tomllib

    project = tomllib.loads((ROOT / "pyproject.toml").read_text())["project"]
    notebook_lock = ROOT / "requirements-notebook.lock"
    pins = locked_versions(notebook_lock)
    wanted = project["optional-dependencies"]["notebook"]
    names = {re.sub(r"[-_.]+", "-", re.split(r"[\[<>=!~ ]", d)[0]).lower() for d in wanted}
    assert "jupyterlab" in names and names <= set(pins), names - set(pins)
    assert all(re.fullmatch(r"[0-9][0-9A-Za-z.]*", v) for v in pins.values())
    assert not set(pins) & set(locked_versions()), set(pins) & set(locked_versions())
    makefile = (ROOT / "Makefile").read_text()
    recipe = makefile[makefile.index("\n$(NOTEBOOK_STAMP):") :].split("\n\n")[0]
    assert f"-r {notebook_lock.name}" in recipe and f"-c {LOCK.name}" in recipe, recipe
    assert "pip check" in recipe
    assert "jupyter lab examples/notebooks/quickstart.ipynb" in makefile
    setup = makefile[makefile.index("\n$(STAMP):") :].split("\n\n")[0]
    assert notebook_lock.name not in setup and "jupyter" not in setup, setup
    assert ".ipynb_checkpoints/" in (ROOT / ".gitignore").read_text().splitlines()


def test_make_clean_removes_no_committed_file(tmp_path: Path) -> None:
    """make clean deletes generated outputs only: none of its paths is tracked by git."""
    env = {k: v for k, v in os.environ.items() if k not in ("MAKEFLAGS", "MAKELEVEL", "MFLAGS")}
    recipe = subprocess.run(
        ["make", "--no-print-directory", "-n", "clean"],
        cwd=ROOT,
        env=env,
        capture_output=True,
        text=True,
        check=True,
    ).stdout.split()
    assert recipe[:2] == ["rm", "-rf"], recipe
    tracked = subprocess.run(
        ["git", "ls-files", "--", *recipe[2:]], cwd=ROOT, capture_output=True, text=True
    )
    if tracked.returncode != 0:  # not a git checkout (an unpacked archive): nothing to check
        return
    assert tracked.stdout == "", f"make clean would delete tracked files:\n{tracked.stdout}"


def test_lock_file_is_where_make_setup_reads_it() -> None:
    """The Makefile's stamp depends on the lock, so a changed lock reinstalls."""
    makefile = (ROOT / "Makefile").read_text()
    assert LOCK.name in makefile and f"-r {LOCK.name}" in makefile
