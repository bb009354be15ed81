"""``make bench``'s shape: a table of sections, each a module with ``run`` and ``render``,
imported only when its section runs (so a child started by one section imports no other's).
The benchmarks themselves are not run here; their modules' imports are checked for cycles by
import-linter (pyproject.toml)."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import pytest

pytestmark = pytest.mark.jsbsim  # bench.common imports the plant

ROOT = Path(__file__).resolve().parents[1]

CHECK = """
import json, sys
from bench.__main__ import SECTIONS
before = sorted(m for m in sys.modules if m.startswith("bench."))
shapes = {}
for s in SECTIONS:
    module = s.load()
    shapes[s.key] = [callable(getattr(module, f, None)) for f in ("run", "render")]
print(json.dumps({"before": before, "shapes": shapes}))
"""


def test_every_section_is_a_module_with_run_and_render_imported_when_used() -> None:
    out = subprocess.run(
        [sys.executable, "-c", CHECK], capture_output=True, text=True, check=True, cwd=ROOT
    ).stdout
    found = json.loads(out.splitlines()[-1])
    assert found["before"] == ["bench.__main__", "bench.common", "bench.report"]
    assert len(found["shapes"]) == 11
    assert all(shape == [True, True] for shape in found["shapes"].values()), found["shapes"]


def test_bench_help_runs() -> None:
    done = subprocess.run(
        [sys.executable, "-m", "bench", "--help"], capture_output=True, text=True, cwd=ROOT
    )
    assert done.returncode == 0, done.stderr
    assert "--only" in done.stdout and "--quick" in done.stdout
