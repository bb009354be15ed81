"""A command whose output goes into a pipe the reader has closed (``probing examples | head``)
ends quietly: nothing on stderr, exit code 141 (128 + SIGPIPE, as a shell reports a program
that SIGPIPE ended).  argparse's help already ends quietly, with 0."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]


@pytest.mark.parametrize("args", [("examples",), ("cache", "info")])
def test_output_into_a_closed_pipe_ends_quietly(args: tuple[str, ...]) -> None:
    """The reader closes its end before the command prints its first line."""
    proc = subprocess.Popen(
        [sys.executable, "-m", "probing", *args],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        cwd=ROOT,
    )
    assert proc.stdout is not None and proc.stderr is not None
    proc.stdout.close()
    err = proc.stderr.read().decode()
    assert proc.wait(timeout=120) == 141, err
    assert err == ""


def test_output_into_an_open_pipe_is_whole() -> None:
    """The other side: a reader that reads everything gets everything, exit code 0."""
    res = subprocess.run(
        [sys.executable, "-m", "probing", "examples"], capture_output=True, text=True, cwd=ROOT
    )
    assert res.returncode == 0 and res.stderr == ""
    assert "fig4/a_deadband.toml" in res.stdout
