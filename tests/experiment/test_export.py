"""``probing design --export-probe/--save-scenario``: the designed probe for a flight computer.

The sequence is regenerated from the C header alone (its array and its comments) and checked
for the m-sequence's properties, against the project's own sequence, and against the shift
register its comments describe; the CSV's time column and amplitude against the design."""

from __future__ import annotations

import dataclasses
import json
import re
import tomllib
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

import probing.experiment.design.design
from probing.cli import main as cli_main
from probing.core.prbs import mls
from probing.experiment.design.probe_export import probe_header
from probing.experiment.scenario import parse_scenario

pytestmark = pytest.mark.jsbsim

#: A cheap design: calm air, no turbulence (a couple of seconds).
DESIGN = ["design", "--aircraft", "737", "--altitude-ft", "15000", "--speed-kcas", "280"]


@pytest.fixture(scope="module")
def exported(tmp_path_factory: pytest.TempPathFactory) -> dict:
    out = tmp_path_factory.mktemp("export")
    files = {"csv": out / "probe.csv", "h": out / "probe.h", "toml": out / "design.toml"}
    argv = [*DESIGN, "--export-probe", str(files["csv"]), "--export-probe", str(files["h"])]
    assert cli_main([*argv, "--save-scenario", str(files["toml"]), "--json"]) == 0
    return files


@pytest.fixture(scope="module")
def design(exported: dict) -> dict:
    """The design's numbers, from its saved scenario."""
    scn = parse_scenario(tomllib.loads(exported["toml"].read_text()))
    return {"scn": scn, "probe": scn.probe}


def parse_header(text: str) -> dict:
    """The array and the comment lines ``name: value`` of an exported header."""
    body = re.search(r"probe_sequence\[PROBE_LENGTH\] = \{(.*?)\};", text, re.S)
    assert body is not None
    seq = np.array([int(v) for v in body.group(1).replace("\n", " ").split(",") if v.strip()])
    comments = dict(re.findall(r"^ \* ([^:\n]+): (.*)$", text, re.M))
    defines = dict(re.findall(r"^#define (PROBE_\w+) (\S+)$", text, re.M))
    return {"seq": seq, "comments": comments, "defines": defines}


def lfsr(order: int, taps: list[int], start: list[int]) -> np.ndarray:
    """The +-1 sequence of the recurrence b[k+n] = XOR of b[k+j], j in taps (0 -> +1)."""
    bits = list(start)
    while len(bits) < 2**order - 1:
        k = len(bits) - order
        bits.append(int(np.bitwise_xor.reduce([bits[k + j] for j in taps])))
    return 1 - 2 * np.array(bits)


def test_the_header_is_an_m_sequence_its_taps_regenerate(exported: dict, design: dict) -> None:
    h = parse_header(exported["h"].read_text())
    seq, c, d = h["seq"], h["comments"], h["defines"]
    n = int(c["order n"])
    m = 2**n - 1
    assert int(c["bits M = 2^n - 1"]) == m == int(d["PROBE_LENGTH"]) == seq.size
    assert int(d["PROBE_ORDER"]) == n == design["probe"].order
    assert set(seq.tolist()) == {-1, 1}
    # balance: the project's convention, one more -1 than +1 (bit 0 -> +1, start all ones)
    assert (seq == 1).sum() == 2 ** (n - 1) - 1 and (seq == -1).sum() == 2 ** (n - 1)
    # the two-level cyclic autocorrelation: M at lag 0, -1 at every other lag
    acf = np.array([seq @ np.roll(seq, k) for k in range(m)])
    assert acf[0] == m and (acf[1:] == -1).all()
    # the project's own sequence, from its first bit (phase 0)
    np.testing.assert_array_equal(seq, mls(n))
    # the shift register the comments describe
    taps = [int(t) for t in c["feedback taps"].split(",")]
    start = re.fullmatch(r"b\[0\] \.\. b\[(\d+)\] = ([01])", c["start state"])
    assert start is not None and int(start.group(1)) == n - 1
    np.testing.assert_array_equal(lfsr(n, taps, [int(start.group(2))] * n), seq)
    poly = " + ".join([f"x^{n}", *(f"x^{j}" if j else "1" for j in sorted(taps, reverse=True))])
    assert c["feedback polynomial over GF(2)"] == poly


def test_the_header_states_the_bit_and_amplitude(exported: dict, design: dict) -> None:
    h = parse_header(exported["h"].read_text())
    probe = design["probe"]
    assert float(h["defines"]["PROBE_BIT_DURATION_S"]) == probe.bit_duration_s
    assert float(h["defines"]["PROBE_AMPLITUDE_DEG"]) == probe.amplitude_deg
    assert h["comments"]["bit duration t0"] == f"{probe.bit_duration_s!r} s"
    assert h["comments"]["amplitude a"] == f"{probe.amplitude_deg!r} deg"


def test_the_csv_is_one_period_one_row_per_bit(exported: dict, design: dict) -> None:
    probe = design["probe"]
    df = pd.read_csv(exported["csv"])
    assert list(df.columns) == ["time_s", "command_deg"]
    assert len(df) == probe.length
    np.testing.assert_allclose(np.diff(df.time_s), probe.bit_duration_s, rtol=1e-9)
    assert df.time_s[0] == 0.0
    np.testing.assert_array_equal(df.command_deg, probe.amplitude_deg * mls(probe.order))
    np.testing.assert_array_equal(df.command_deg.to_numpy(), probe.bits(1))


def test_the_json_and_the_files_agree(exported: dict, design: dict) -> None:
    probe = design["probe"]
    h = parse_header(exported["h"].read_text())
    np.testing.assert_array_equal(
        pd.read_csv(exported["csv"]).command_deg, probe.amplitude_deg * h["seq"]
    )


def test_the_saved_scenario_runs(exported: dict, tmp_path: Path) -> None:
    toml = exported["toml"]
    scn = parse_scenario(tomllib.loads(toml.read_text()))
    assert cli_main(["run", str(toml), "--out", str(tmp_path / "o")]) == 0
    assert (tmp_path / "o" / scn.name / "probing.parquet").is_file()


def test_a_throttle_probe_is_exported_in_its_unit() -> None:
    from probing.experiment.design.probe_export import probe_csv
    from probing.experiment.scenario import load_scenario

    root = Path(__file__).resolve().parents[2]
    scn = load_scenario(root / "scenarios" / "baseline-737.toml")
    probe = dataclasses.replace(scn.probe_section, surface="throttle", amplitude_deg=0.01)  # norm
    scn = dataclasses.replace(scn, probe_section=probe)
    assert probe_csv(scn).startswith("time_s,command_norm\n")
    assert "#define PROBE_AMPLITUDE_NORM 0.01" in probe_header(scn)


@pytest.mark.parametrize(
    ("dt_s", "steps", "decimals"), [(0.01, 1, 2), (0.01, 3, 2), (0.1, 3, 1), (0.005, 1, 3)]
)
def test_the_csv_times_are_exact_decimals_of_the_step(dt_s, steps, decimals) -> None:
    """k t0 as decimal text at the simulation step's decimals: bit 510 of 0.01 s bits starts
    at 5.10 s, not 5.1000000000000005 (the float product)."""
    from probing.experiment.design.probe_export import probe_csv
    from probing.experiment.scenario import load_scenario

    root = Path(__file__).resolve().parents[2]
    scn = load_scenario(root / "scenarios" / "baseline-737.toml").replace(
        {"simulation.dt_s": dt_s, "probe.bit_duration_s": steps * dt_s, "probe.order": 9}
    )
    rows = probe_csv(scn).splitlines()[1:]
    scale = 10**decimals
    ticks = round(steps * dt_s * scale)  # the bit in units of the last decimal
    for k, row in enumerate(rows):
        whole, part = divmod(k * ticks, scale)
        assert row.split(",")[0] == f"{whole}.{part:0{decimals}d}", (k, row)


@pytest.fixture
def no_design(monkeypatch: pytest.MonkeyPatch) -> None:
    def work(*args: object, **kwargs: object) -> None:
        raise AssertionError("the design started before the output paths were checked")

    monkeypatch.setattr(probing.experiment.design.design, "recommend", work)


@pytest.mark.parametrize(
    ("files", "needle"),
    [
        (["--export-probe", "{d}/probe.txt"], "must end in .csv or .h"),
        (["--export-probe", "{d}/a-folder.h"], "is a folder, not a file"),
        (["--export-probe", "{d}/p.csv", "--save-scenario", "{d}/a-file/s.toml"], "below a file"),
        (["--save-scenario", "{d}/a-folder.h"], "is a folder, not a file"),
        (["--export-probe", "{d}/p.h", "--export-probe", "{d}/p.h"], "named twice"),
        (["--save-scenario", "{d}/design.json"], "must end in .toml"),
        (["--save-scenario", "{d}/design"], "must end in .toml"),
    ],
)
def test_bad_output_paths_are_one_line_exit_2_and_nothing_written(
    files: list[str], needle: str, tmp_path: Path, capsys: pytest.CaptureFixture[str], no_design
) -> None:
    (tmp_path / "a-folder.h").mkdir()
    (tmp_path / "a-file").write_text("mine")
    before = sorted(p.name for p in tmp_path.rglob("*"))
    argv = [*DESIGN, *[f.format(d=tmp_path) for f in files]]
    assert cli_main(argv) == 2
    out, err = capsys.readouterr()
    assert out == "" and err.count("\n") == 1 and needle in err, err
    assert sorted(p.name for p in tmp_path.rglob("*")) == before


def test_simultaneous_has_no_probe_to_export(tmp_path: Path, capsys) -> None:
    argv = ["design", "--simultaneous", "x.toml", "--export-probe", str(tmp_path / "p.h")]
    assert cli_main(argv) == 2
    assert "no probe to write" in capsys.readouterr().err
    assert list(tmp_path.iterdir()) == []


def test_json_output_is_unchanged_by_the_exports(exported: dict, capsys) -> None:
    assert cli_main([*DESIGN, "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    assert out["scenario_toml"] == exported["toml"].read_text()


def test_each_file_written_is_named_on_its_own_line(tmp_path: Path, capsys) -> None:
    """``wrote FILE`` per file, after the design; with --json on stderr, so stdout stays one
    JSON object."""
    files = [tmp_path / "probe.csv", tmp_path / "probe.h", tmp_path / "design.toml"]
    argv = [*DESIGN, "--export-probe", str(files[0]), "--export-probe", str(files[1])]
    argv += ["--save-scenario", str(files[2])]
    assert cli_main(argv) == 0
    out, err = capsys.readouterr()
    assert out.splitlines()[-3:] == [f"wrote {f}" for f in files] and err == ""
    for f in files:
        f.unlink()
    assert cli_main([*argv, "--json"]) == 0
    out, err = capsys.readouterr()
    assert json.loads(out)["feasible"] is True
    assert err.splitlines() == [f"wrote {f}" for f in files]
    assert all(f.is_file() for f in files)
