"""Test-session settings, the one factory of JSBSim aircraft for the tests and their one 737
base scenario.

The reference-twin cache lives in a temporary folder, so the tests neither read twins a
developer's runs left behind nor fill the user's cache.
"""

from __future__ import annotations

import copy
import os
import re
import signal
import subprocess
import time
from collections.abc import Callable, Iterator
from importlib import metadata
from pathlib import Path
from typing import Any

import pytest

# Figures are drawn into files: no window, whatever display the machine has.
os.environ.setdefault("MPLBACKEND", "Agg")

LOCK = Path(__file__).resolve().parents[1] / "requirements.lock"
#: The packages whose numbers the results depend on, named first in the session header.
NUMERIC = ("jsbsim", "numpy", "scipy", "pandas", "pyarrow", "matplotlib", "dask")


def locked_versions(lock: Path = LOCK) -> dict[str, str]:
    """``{normalised name: version}`` of every ``name==version`` line of ``lock``
    (requirements.lock)."""
    pins = {}
    for line in lock.read_text().splitlines():
        if line and not line.startswith("#"):
            name, version = line.split("==")
            pins[re.sub(r"[-_.]+", "-", name).lower()] = version.strip()
    return pins


def installed_version(name: str) -> str | None:
    """The installed distribution's version, or None if it is not installed."""
    try:
        return metadata.version(name)
    except metadata.PackageNotFoundError:
        return None


#: OpenBLAS's x86-64 kernels and the CPU flag each needs (forcing one the CPU lacks crashes):
#: the generic SSE3 kernels OpenBLAS falls back to on a processor it does not know, and those
#: of the processors since 2011.
BLAS_KERNELS = {
    "Prescott": "pni",  # SSE3, as /proc/cpuinfo names it
    "Sandybridge": "avx",
    "Haswell": "avx2",
    "Zen": "avx2",
    "SkylakeX": "avx512f",
}
#: numpy's own run-time targets that use AVX-512 (its exp, log, power, ... differ in the
#: last bit from its AVX2 ones): a process given the kernel of a processor without AVX-512
#: runs without them, as numpy would on that processor.
NUMPY_AVX512 = ("X86_V4", "AVX512_ICL", "AVX512_SPR")


def blas_kernel_environment(kernel: str) -> dict[str, str]:
    """The environment of a process that computes as a processor of OpenBLAS's ``kernel``
    would: OpenBLAS forced to it (and saying which it ran), and numpy without its AVX-512
    paths unless the kernel is an AVX-512 one."""
    from numpy._core._multiarray_umath import __cpu_dispatch__

    env = {**os.environ, "OPENBLAS_CORETYPE": kernel, "OPENBLAS_VERBOSE": "2"}
    if BLAS_KERNELS[kernel] != "avx512f":
        env["NPY_DISABLE_CPU_FEATURES"] = " ".join(f for f in NUMPY_AVX512 if f in __cpu_dispatch__)
    return env


def run_with_blas_kernel(kernel: str, args: list[str]) -> str:
    """Run ``python ARGS`` as a processor of OpenBLAS's ``kernel`` would
    (:func:`blas_kernel_environment`) and return its stdout; skip the test where the CPU
    cannot run that kernel, fail if OpenBLAS ran another or the run fails."""
    import subprocess
    import sys

    try:
        cpuinfo = Path("/proc/cpuinfo").read_text()
    except OSError:
        cpuinfo = ""
    flags = {f for line in cpuinfo.splitlines() if line.startswith("flags") for f in line.split()}
    if BLAS_KERNELS[kernel] not in flags:
        pytest.skip(f"this CPU has no {BLAS_KERNELS[kernel]} for OpenBLAS's {kernel} kernel")
    env = blas_kernel_environment(kernel)
    run = subprocess.run([sys.executable, *args], env=env, capture_output=True, text=True)
    assert run.returncode == 0, run.stderr
    # OpenBLAS runs Zen on Haswell's kernels, and names its Prescott kernels by the first
    # core that shares them, Katmai
    runs = {"Zen": "Haswell", "Prescott": "Katmai"}.get(kernel, kernel)
    assert f"Core: {runs}" in run.stdout + run.stderr  # the kernel OpenBLAS says it ran
    return run.stdout


def pytest_report_header(config: pytest.Config) -> list[str]:
    """The session header names the pinned versions it runs with (and any that differ)."""
    pins = locked_versions()
    off = [
        f"{name} {installed_version(name)} (lock: {pins[name]})"
        for name in sorted(pins)
        if installed_version(name) != pins[name]
    ]
    shown = ", ".join(f"{name} {pins[name]}" for name in NUMERIC)
    lines = [f"pinned (requirements.lock, {len(pins)} packages): {shown}, ..."]
    lines.append("NOT as pinned: " + "; ".join(off) if off else "all installed as pinned")
    if os.environ.get("OPENBLAS_CORETYPE"):
        lines.append(f"OPENBLAS_CORETYPE={os.environ['OPENBLAS_CORETYPE']}")
    return lines


#: The tests' 737 scenario (read through :func:`base_scenario`, which copies it).
_BASE_737: dict[str, Any] = {
    "name": "t",
    "aircraft": {"model": "737"},
    "condition": {"altitude_ft": 15000, "speed_kcas": 280},
    "simulation": {"dt_s": 0.01},
    "probe": {
        "order": 9,
        "bit_duration_s": 0.01,
        "amplitude_deg": 0.005,
        "periods": 8,
        "settle_periods": 2,
    },
    "nonlinearity": {"type": "none"},
    "output": {"channels": ["theta_rad", "q_rad_s", "alpha_rad"], "drift": "reference"},
}


def base_scenario(changes: dict[str, Any] | None = None, /, **entries: Any) -> dict[str, Any]:
    """The tests' 737 base scenario, as a fresh deep copy to change at will.

    Parameters
    ----------
    changes
        Dotted keys set in their section, e.g. ``{"probe.order": 6}``.
    **entries
        Top-level entries set whole, e.g. ``name="b"`` or ``disturbance={...}`` (a new one
        goes last).

    Returns
    -------
    dict
        The scenario as :func:`probing.experiment.scenario.parse_scenario` takes it: the 737
        at 15000 ft and 280 KCAS, dt 0.01 s, an order-9 elevator probe of 0.005 deg with
        0.01 s bits, 8 periods of which 2 settle, no nonlinearity, theta, q and alpha.
    """
    data = copy.deepcopy(_BASE_737)
    for key, value in (changes or {}).items():
        section, name = key.split(".")
        data[section][name] = copy.deepcopy(value)
    data.update(copy.deepcopy(entries))
    return data


@pytest.fixture(scope="session", autouse=True)
def _private_twin_cache(tmp_path_factory: pytest.TempPathFactory) -> Iterator[None]:
    """One twin cache per test run, shared by its workers (pytest-xdist's, whose temporary
    folders sit side by side in the run's): a twin one worker built, the others read.  Twins
    appear whole (written aside and renamed, :mod:`probing.sim.twins`), so workers building
    the same one at once each write their own and the last rename wins, as processes do."""
    run = tmp_path_factory.getbasetemp()
    if os.environ.get("PYTEST_XDIST_WORKER"):
        run = run.parent
    old = os.environ.get("PROBING_TWIN_CACHE")
    os.environ["PROBING_TWIN_CACHE"] = str(run / "twins")
    yield
    if old is None:
        os.environ.pop("PROBING_TWIN_CACHE", None)
    else:
        os.environ["PROBING_TWIN_CACHE"] = old


@pytest.fixture(scope="session")
def new_plant() -> Callable[..., Any]:
    """``new_plant(model="gtm_t2", dt_s=1/200, **kwargs)``: a fresh, untrimmed
    :class:`probing.sim.plant.Plant` (sanitised model, quiet); its FGFDMExec is ``.fdm``.

    Trim it with :meth:`~probing.sim.plant.Plant.trim`, the project's one trim path.
    """
    from probing.sim.plant import Plant

    def make(model: str = "gtm_t2", dt_s: float = 1.0 / 200.0, **kwargs: Any) -> Plant:
        return Plant(model, dt_s, **kwargs)

    return make


@pytest.fixture(scope="session")
def toy_linear() -> Any:
    """A made-up :class:`probing.sim.linear.LinearResponse`: a slow and a fast mode, two
    outputs (one with feed-through), a three-step actuator."""
    import numpy as np

    from probing.sim.linear import LinearResponse

    return LinearResponse(
        a=np.array([[0.995, 0.01], [0.0, 0.9]]),
        b=np.array([0.0, 1.0]),
        c=np.array([[1.0, 0.0], [0.2, 1.0]]),
        d=np.array([0.0, 0.3]),
        channels=("theta_rad", "q_rad_s"),
        actuator=np.array([0.6, 0.3, 0.1]),
    )


@pytest.fixture(scope="session")
def stepped() -> Callable[..., Any]:
    """``stepped(lin, asked)``: a LinearResponse stepped one step at a time, as its docstring
    defines it (the actuator as a convolution, then x(k+1) = A x(k) + B u(k), output
    C x(k) + D u(k-1)), from rest; shape (N, C).  The oracle of its vectorised methods."""
    import numpy as np

    def step(lin: Any, asked: Any) -> Any:
        asked = np.asarray(asked, dtype=float)
        u = np.convolve(asked, lin.actuator)[: asked.size]
        x = np.zeros(lin.a.shape[0])
        out = np.empty((asked.size, lin.c.shape[0]))
        for k in range(asked.size):
            out[k] = lin.c @ x + (lin.d * u[k - 1] if k else 0.0)
            x = lin.a @ x + lin.b * u[k]
        return out

    return step


def interrupt_when(cmd: list[str], out: Path, delay_s: float) -> subprocess.CompletedProcess:
    """Run ``cmd``; ``delay_s`` after the folder ``out`` appears (-1: once anything appears
    in it, the files' moment), send it Ctrl-C (SIGINT); its return code and streams."""
    proc = subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    deadline = time.monotonic() + 120
    while time.monotonic() < deadline and proc.poll() is None:
        if out.exists() and (delay_s >= 0 or any(out.iterdir())):
            break
        time.sleep(0.001)
    time.sleep(max(delay_s, 0.0))
    proc.send_signal(signal.SIGINT)
    stdout, stderr = proc.communicate(timeout=120)
    return subprocess.CompletedProcess(cmd, proc.returncode, stdout, stderr)
