"""The README's Python example runs and says what it claims."""

import re
from pathlib import Path

import numpy as np
import pytest

README = Path(__file__).resolve().parent.parent / "README.md"


def _python_block(marker: str) -> str:
    """The README's Python example that holds ``marker``."""
    blocks = re.findall(r"```python\n(.*?)```", README.read_text(), flags=re.S)
    found = [b for b in blocks if marker in b]
    assert len(found) == 1, f"README lost its Python example with {marker}"
    return found[0]


def test_readme_example_runs() -> None:
    namespace: dict = {}
    block = _python_block("StreamingCorrelator")
    exec(compile(block, "README.md", "exec"), namespace)  # our own README
    a = namespace["probe"].amplitude_deg
    np.testing.assert_allclose(namespace["nl"].apparent(a), (2 * a / 3, 0.0), rtol=1e-12)
    ratio = namespace["corr"].pulse_response(average=2) / namespace["h"]
    np.testing.assert_allclose(ratio, 2 / 3, rtol=1e-9)
    # Compensation recovers the probing output the plant gives without the deadband.
    h, sigma = namespace["h"], namespace["probe"].reference()
    m = h.size
    expected_z = a * ((m + 1) * h - h.sum())
    from probing import compensate

    got = compensate(namespace["est"].z[-1], namespace["nl"], a)
    np.testing.assert_allclose(got, expected_z, rtol=1e-9, atol=1e-12)
    assert sigma.size == m


def test_documented_commands_write_under_the_ignored_results_folder() -> None:
    """A command copied from the README or docs/ leaves `git status` clean: every lower-case
    `--out` folder it names is under `results/`, which .gitignore ignores (a placeholder in
    capitals, DIR or TMP, is the reader's own)."""
    root = README.parent
    assert "/results/" in (root / ".gitignore").read_text().split()
    outside = []
    for page in (README, *sorted((root / "docs").glob("*.md"))):
        for number, line in enumerate(page.read_text().splitlines(), 1):
            for folder in re.findall(r"--out ([a-z][^\s`]*)", line):
                if not folder.startswith("results/") and folder != "results":
                    outside.append(f"{page.name}:{number}: --out {folder}")
    assert not outside, outside


@pytest.mark.jsbsim
def test_readme_api_example_runs_and_saves_what_it_says(tmp_path, monkeypatch) -> None:
    """The README's Python API example flies, draws and saves under results/ (ignored)."""
    monkeypatch.chdir(tmp_path)
    namespace: dict = {}
    exec(compile(_python_block("probing.fly"), "README.md", "exec"), namespace)
    flight = namespace["flight"]
    assert flight.scenario.amplitude_deg == 0.01
    assert len(namespace["figure"].axes) == 2
    saved = tmp_path / "results" / "python" / flight.name
    assert sorted(p.name for p in saved.iterdir()) == list(sorted(flight.files))
