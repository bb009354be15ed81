"""Where a run's time goes, for ``make bench``: cProfile's own time per category of code, and
its table with JSBSim's ``run()`` set apart (the step-loop and fig4 sections)."""

from __future__ import annotations

import cProfile
import pstats
import time
from collections.abc import Callable
from pathlib import Path

#: Profile categories, matched in order against "file:function" of each profiled function.
PROFILE_GROUPS: tuple[tuple[str, tuple[str, ...]], ...] = (
    ("stepping loop (JSBSim run() + property set/get)", ("plant.py:step", "'append' of 'list'")),
    ("Parquet output (pyarrow, storage)", ("pyarrow", "storage.py")),
    ("correlator (FFT overlap-add)", ("correlator.py", "scipy/fft", "pocketfft")),
    ("reference-twin cache I/O", ("twins.py", "BufferedWriter", "BufferedReader")),
    ("model load, trim, calibration", ("plant.py", "aircraft.py", "xml/etree", "ElementTree")),
    ("provenance (git revision)", ("subprocess", "selectors", "'poll'", "storage.py:git")),
)


OTHER = "other (numpy glue, noise, nonlinearity, run loop)"
STEPPING = PROFILE_GROUPS[0][0]


def profile(fn: Callable[[], object]) -> dict:
    """Run ``fn`` under cProfile: wall time, own time (tottime) per category, top functions.

    cProfile does not see JSBSim's Cython calls: ``run()`` and the property calls are
    counted in the Python function calling them (``Plant.step``, ``Plant.__init__`` for
    the model load).
    """
    profiler = cProfile.Profile()
    t0 = time.perf_counter()
    profiler.enable()
    try:
        fn()
    finally:
        profiler.disable()
    wall = time.perf_counter() - t0
    groups: dict[str, float] = {name: 0.0 for name, _ in PROFILE_GROUPS}
    groups[OTHER] = 0.0
    funcs = []
    stats = pstats.Stats(profiler).stats  # type: ignore[attr-defined]
    for (file, line, func), (_, _, tt, _, _) in stats.items():
        label = f"{file}:{func}"
        funcs.append((f"{Path(file).name}:{line}({func})" if file != "~" else func, tt))
        for name, patterns in PROFILE_GROUPS:
            if any(p in label for p in patterns):
                groups[name] += tt
                break
        else:
            groups[OTHER] += tt
    funcs.sort(key=lambda x: -x[1])
    return {"wall_s": wall, "groups_s": groups, "top": funcs[:8]}


def render_profile(p: dict, steps: int, run_s: float) -> list[str]:
    """The categories of :func:`profile`, the stepping loop split into ``run()`` and the rest.

    ``run_s`` is the estimated time in JSBSim's ``run()`` (steps times the bare per-step
    time measured in the same benchmark).
    """
    loop = p["groups_s"][STEPPING]
    run_s = min(run_s, loop)
    parts = {
        "JSBSim run() (steps x bare per-step time)": run_s,
        "property writes/reads and loop (rest of Plant.step)": loop - run_s,
    }
    parts.update({k: v for k, v in p["groups_s"].items() if k != STEPPING})
    total = sum(parts.values())
    non_bare = total - run_s
    lines = [
        "| part | s | us per simulated step | share of total | share of non-bare time |",
        "|---|---|---|---|---|",
    ]
    for name, sec in parts.items():
        nb = "" if name.startswith("JSBSim run()") else f"{100 * sec / non_bare:.0f} %"
        lines.append(
            f"| {name} | {sec:.3f} | {1e6 * sec / steps:.2f} | {100 * sec / total:.0f} % | {nb} |"
        )
    largest = sorted(
        ((sec, name) for name, sec in parts.items() if not name.startswith("JSBSim run()")),
        reverse=True,
    )[:3]
    lines += [
        "",
        "Largest parts beyond the bare `run()`: "
        + "; ".join(f"{name} {100 * sec / non_bare:.0f} %" for sec, name in largest)
        + ".",
    ]
    lines += ["", "Top functions by own time (tottime):", "", "| function | s |", "|---|---|"]
    lines += [f"| `{name}` | {tt:.3f} |" for name, tt in p["top"]]
    lines.append("")
    return lines
