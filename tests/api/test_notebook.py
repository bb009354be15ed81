"""The quickstart notebook (examples/notebooks/quickstart.ipynb) runs in a kernel of the
pinned environment and says what it claims: eq. (10)'s gain at three amplitudes, a damage
case found after its onset and called "airframe", a saved flight read back equal; and it is
committed without outputs, so running it leaves the repository as it was."""

from __future__ import annotations

import json
import subprocess
from pathlib import Path

import pytest
from notebooks import run_notebook

ROOT = Path(__file__).resolve().parents[2]
NOTEBOOK = ROOT / "examples" / "notebooks" / "quickstart.ipynb"


def test_the_notebook_is_committed_without_outputs() -> None:
    nb = json.loads(NOTEBOOK.read_text())
    code = [c for c in nb["cells"] if c["cell_type"] == "code"]
    assert code and all(c["outputs"] == [] and c["execution_count"] is None for c in code)
    assert nb["metadata"]["kernelspec"]["name"] == "python3"


def _stream(cell) -> str:
    return "".join(o.get("text", "") for o in cell.outputs if o.output_type == "stream")


def _status() -> str:
    """``git status --porcelain --untracked-files=all`` of the repository: every untracked
    file named, not only its folder."""
    return subprocess.run(
        ["git", "status", "--porcelain", "--untracked-files=all"],
        cwd=ROOT,
        capture_output=True,
        text=True,
    ).stdout


@pytest.mark.slow
@pytest.mark.jsbsim
def test_the_quickstart_notebook_runs_and_says_what_it_claims() -> None:
    """Run as Jupyter runs it, in its own folder (it left examples/notebooks/results/
    untracked): the repository's status is the same afterwards."""
    before = NOTEBOOK.read_bytes()
    status = _status()
    nb = run_notebook(NOTEBOOK, NOTEBOOK.parent)
    got = json.loads(_stream(nb.cells[-1]).splitlines()[-1])
    gains = got["gains"]
    assert gains["amplitude_deg"] == [0.0025, 0.005, 0.01]
    assert gains["eq10_gain"] == pytest.approx([1 / 3, 2 / 3, 5 / 6], abs=1e-12)
    # eq. (10) on the pitch rate, against the flight without the dead band: within 1 %
    assert gains["measured_gain"] == pytest.approx(gains["eq10_gain"], rel=0.01)
    period_s = 255 * 0.01
    assert got["onset_s"] < got["first_alarm_s"] <= got["onset_s"] + 3 * period_s
    assert got["verdict"] == "airframe" and got["read_back_equal"] is True
    figures = [
        c for c in nb.cells if any("image/png" in o.get("data", {}) for o in c.get("outputs", []))
    ]
    assert len(figures) >= 4  # truth, louder, the gain, the alarm
    (saved,) = [c for c in nb.cells if "saved = loud.save(" in c.source]
    (printed,) = [o.text for o in saved.outputs if o.get("name") == "stdout"]
    folder = Path(printed.strip())
    assert folder.name == "fig4-a-deadband" and not folder.is_relative_to(ROOT), folder
    assert NOTEBOOK.read_bytes() == before
    assert _status() == status
