"""The study's results keep their bytes when the code is made faster (issue [5/5]).

Short versions of the monitor study's flights (``scenarios/monitor-realisable``: the three
references, a damage case, a stuck sensor whose gust twin diverges, a dead band, a loss of
effectiveness, a sensor bias) and of a grouped open-loop sweep (the Fig. 4 GTM with a
backlash) are flown through ``run_sweep``, the study's own path, and every file they write is
reduced to a digest of its content: each Parquet file's column names, types and values (the
footer's versions and timing aside), ``point.json`` without its accounting of the work (wall
time, steps simulated).  The digests were recorded by the code before the speed work
(``tests/data/result_digests.json``); a change that moves a single bit of any result fails
here.

Regenerate, only for a change that is meant to change results (and say so in its commit)::

    .venv/bin/python tests/sweep/test_result_bytes.py

The same flights are flown in a process forced to each of OpenBLAS's x86-64 kernels, and
must write the same bytes there (``--print`` writes the digests to stdout instead).
"""

from __future__ import annotations

import hashlib
import json
import sys
import tempfile
from pathlib import Path

import pyarrow.parquet as pq
import pytest

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))  # run as a script: conftest
from conftest import BLAS_KERNELS, run_with_blas_kernel

ROOT = Path(__file__).resolve().parents[2]
DIGESTS = ROOT / "tests" / "data" / "result_digests.json"
STUDY_BASE = ROOT / "scenarios" / "references" / "base.toml"
FIG4_BASE = ROOT / "scenarios" / "fig4" / "baseline.toml"

#: name -> sweep text (its base prepended): the study's flights cut to 72-80 periods, their
#: onsets those of the study's first seeds (after the 60 periods of baseline and gap).
SWEEPS = {
    "damage5": (
        'kind = "monitor"\n[fixed]\n"probe.periods" = 75\n"fault.type" = "gtm_damage"\n'
        '"fault.case" = 5\n"disturbance.seed" = 1\n"fault.onset_s" = 169.582\n'
        '[grid]\n"output.drift" = ["gust", "detrend", "oracle"]\n'
    ),
    "sensor-stuck": (
        'kind = "monitor"\n[fixed]\n"probe.periods" = 80\n"fault.type" = "sensor_stuck"\n'
        '"fault.channel" = "theta_rad"\n"disturbance.seed" = 1\n"fault.onset_s" = 179.003\n'
        '[grid]\n"output.drift" = ["gust"]\n'
    ),
    "deadband": (
        'kind = "monitor"\n[fixed]\n"probe.periods" = 80\n"fault.type" = "nonlinearity"\n'
        '"fault.nonlinearity" = "deadband"\n"disturbance.seed" = 2\n'
        '"fault.onset_s" = 189.246\n"probe.amplitude_deg" = 1.0\n"fault.lower_deg" = -0.2\n'
        '"fault.upper_deg" = 0.2\n[grid]\n"output.drift" = ["gust", "oracle"]\n'
    ),
    "effectiveness": (
        'kind = "monitor"\n[fixed]\n"probe.periods" = 72\n"fault.type" = "effectiveness"\n'
        '"fault.scale" = 0.5\n"disturbance.seed" = 1\n"fault.onset_s" = 155.276\n'
        '[grid]\n"output.drift" = ["detrend"]\n'
    ),
    "sensor-bias": (
        'kind = "monitor"\n[fixed]\n"probe.periods" = 72\n"fault.type" = "sensor_bias"\n'
        '"fault.channel" = "theta_rad"\n"fault.bias" = 0.00872664626\n"disturbance.seed" = 3\n'
        '"fault.onset_s" = 160.0\n'
        '[grid]\n"output.drift" = ["gust"]\n'
    ),
}
#: The open-loop sweep of Fig. 4's GTM, grouped (one trim, a forked child per point).
FIG4_SWEEP = '[grid]\n"nonlinearity.type" = ["backlash"]\n"nonlinearity.width_deg" = [0.0, 0.05]\n'


def _sweep_files() -> list[tuple[str, str]]:
    """(name, base) of every sweep the test flies."""
    study = [(name, str(STUDY_BASE)) for name in SWEEPS]
    return [*study, ("fig4-backlash", str(FIG4_BASE))]


def file_digest(path: Path) -> str:
    """sha256 of a result file's content: a Parquet file's column names, types and values
    (its metadata, which names versions and times, aside); ``point.json`` without its
    accounting of the work (wall time, JSBSim steps); any other file byte for byte."""
    h = hashlib.sha256()
    if path.suffix == ".parquet":
        table = pq.read_table(path)
        for name, column in zip(table.column_names, table.columns, strict=True):
            h.update(f"{name}:{column.type}\n".encode())
            if column.type in ("string", "large_string") or str(column.type).startswith(
                "dictionary"
            ):
                h.update("\x00".join(map(str, column.to_pylist())).encode())
            else:
                h.update(column.to_numpy().tobytes())
    elif path.name == "point.json":
        record = json.loads(path.read_text())
        record.pop("wall_s", None)
        record.pop("steps_simulated", None)
        h.update(json.dumps(record, sort_keys=True).encode())
    else:
        h.update(path.read_bytes())
    return h.hexdigest()


def fly_all(out: Path) -> dict[str, str]:
    """Fly every sweep into ``out``: ``{relative path: digest}`` of every result file."""
    from probing.sweep import load_sweep, run_sweep

    digests = {}
    for name, base in _sweep_files():
        body = SWEEPS.get(name, FIG4_SWEEP)
        path = out / f"{name}.toml"
        path.write_text(f'name = "bytes-{name}"\nbase = "{base}"\n{body}')
        folder = out / f"bytes-{name}"
        result = run_sweep(load_sweep(path), out, jobs=1, progress=False)
        assert result.errors == 0, result.messages
        for file in sorted((folder / "points").rglob("*")):
            if file.is_file():
                digests[str(file.relative_to(out))] = file_digest(file)
    return digests


@pytest.mark.jsbsim
@pytest.mark.slow
def test_the_study_results_keep_their_bytes(tmp_path: Path) -> None:
    """Every file of the study's flights (three references, damage, a stuck sensor with a
    diverging twin, a dead band, effectiveness, a sensor bias) and of a grouped open-loop
    sweep has the content recorded before the speed work."""
    expected = json.loads(DIGESTS.read_text())
    got = fly_all(tmp_path)
    assert sorted(got) == sorted(expected)
    changed = [name for name in expected if got[name] != expected[name]]
    assert not changed, f"results changed: {changed}"
    # The accounting left out above: a gust flight steps two aircraft, the aircraft and its
    # gust twin (72 periods of 255 steps each).
    (record,) = [
        json.loads(p.read_text()) for p in tmp_path.glob("bytes-sensor-bias/*/*/point.json")
    ]
    assert record["steps_simulated"] == 2 * 72 * 255


@pytest.mark.jsbsim
@pytest.mark.slow
@pytest.mark.parametrize("kernel", sorted(BLAS_KERNELS))
def test_the_study_results_are_the_same_bytes_under_every_blas_kernel(kernel: str) -> None:
    """The same flights in a process that computes as a processor of each of OpenBLAS's
    x86-64 kernels would (numpy without AVX-512 off the AVX-512 kernel) write the recorded
    bytes: a result may not depend on the machine's BLAS.  Before the monitor and the
    linearised prediction summed in a fixed order, SkylakeX moved every monitor.parquet and a
    point.json, and a detrended gain change by 0.2."""
    out = run_with_blas_kernel(kernel, [__file__, "--print"])
    assert json.loads(out) == json.loads(DIGESTS.read_text())


if __name__ == "__main__":
    with tempfile.TemporaryDirectory() as tmp:
        digests = fly_all(Path(tmp))
    text = json.dumps(digests, indent=1, sort_keys=True) + "\n"
    if sys.argv[1:] == ["--print"]:  # the digests of this process, for the kernel test
        print(text, end="")
    else:
        DIGESTS.write_text(text)
        print(f"{len(digests)} files -> {DIGESTS}", file=sys.stderr)
