"""The README's Python example runs and says what it claims."""

import re
from pathlib import Path

import numpy as np

README = Path(__file__).resolve().parent.parent / "README.md"


def test_readme_example_runs() -> None:
    blocks = re.findall(r"```python\n(.*?)```", README.read_text(), flags=re.S)
    assert blocks, "README lost its Python example"
    namespace: dict = {}
    exec(compile(blocks[0], "README.md", "exec"), namespace)  # our own README
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
