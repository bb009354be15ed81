"""What the layering promises a user: the core and scenario validation load no simulator,
no plotting and no tables; the public API is at the top.  (The import rules themselves are
import-linter contracts in pyproject.toml, checked by make lint.)"""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
HEAVY = ("jsbsim", "matplotlib", "pandas")


def loaded_after(code: str) -> dict[str, bool]:
    """Run ``code`` in a fresh interpreter; which of :data:`HEAVY` it imported."""
    probe = (
        f"{code}\nimport json, sys\nprint(json.dumps({{m: m in sys.modules for m in {HEAVY!r}}}))"
    )
    out = subprocess.run(
        [sys.executable, "-c", probe], capture_output=True, text=True, check=True, cwd=ROOT
    ).stdout
    return json.loads(out.splitlines()[-1])


def test_the_public_api_is_at_the_top_and_light() -> None:
    code = (
        "from probing import Probe, mls, StreamingCorrelator, Deadband, Saturation, Relay, "
        "HysteresisRelay, Backlash, RateLimit, compensate\n"
        "import probing\nassert probing.__version__ != 'unknown'"
    )
    assert loaded_after(code) == dict.fromkeys(HEAVY, False)


def test_validating_a_scenario_or_a_sweep_loads_no_simulator() -> None:
    code = (
        "from probing.experiment.scenario import load_scenario\n"
        "load_scenario('scenarios/baseline-737.toml')\n"
        "load_scenario('scenarios/monitor-lateral/base-aileron.toml')\n"
        "from probing.sweep import load_sweep\n"
        "load_sweep('scenarios/sweeps/backlash-width.toml')"
    )
    assert loaded_after(code) == dict.fromkeys(HEAVY, False)


def test_one_version_string() -> None:
    import tomllib
    from importlib.metadata import version

    import probing

    pyproject = tomllib.loads((ROOT / "pyproject.toml").read_text())["project"]["version"]
    assert probing.__version__ == version("probing") == pyproject
    sources = [p for p in ROOT.glob("probing/**/*.py") if f'"{pyproject}"' in p.read_text()]
    assert sources == []  # the version is written in pyproject.toml only


def test_analysis_loads_no_simulator() -> None:
    """Every ``analysis`` module draws from stored files: importing them all loads neither
    JSBSim, the plant nor the runner (the constants they share live in light modules)."""
    simulator = ("jsbsim", "probing.sim.plant", "probing.experiment.run")
    code = (
        "import importlib, json, pkgutil, sys\n"
        "import analysis\n"
        "names = [m.name for m in pkgutil.walk_packages(analysis.__path__, 'analysis.')]\n"
        "for name in names:\n"
        "    importlib.import_module(name)\n"
        f"print(json.dumps([len(names), [m for m in {simulator!r} if m in sys.modules]]))"
    )
    out = subprocess.run(
        [sys.executable, "-c", code], capture_output=True, text=True, check=True, cwd=ROOT
    ).stdout
    n_modules, loaded = json.loads(out.splitlines()[-1])
    assert n_modules >= 12  # every module was imported
    assert loaded == []


def test_no_code_assigns_to_another_objects_private_attribute() -> None:
    """``x._name = ...`` (or ``+=``) only on ``self`` or ``cls``: an object owns its private
    state (the closed loop used to write the plant's step count and scheduled damage)."""
    import ast

    root = Path(__file__).resolve().parents[1]
    found = []
    for path in sorted([*root.glob("probing/**/*.py"), *root.glob("analysis/*.py")]):
        for node in ast.walk(ast.parse(path.read_text())):
            targets = (
                node.targets
                if isinstance(node, ast.Assign)
                else [node.target]
                if isinstance(node, ast.AugAssign | ast.AnnAssign)
                else []
            )
            for t in targets:
                for sub in ast.walk(t):
                    if (
                        isinstance(sub, ast.Attribute)
                        and sub.attr.startswith("_")
                        and not sub.attr.startswith("__")
                        and not (
                            isinstance(sub.value, ast.Name) and sub.value.id in ("self", "cls")
                        )
                    ):
                        found.append(f"{path.relative_to(root)}:{node.lineno} {ast.unparse(t)}")
    assert found == []
