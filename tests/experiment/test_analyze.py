"""``probing analyze`` on records of systems nobody here simulated: a known discrete system
driven through scipy.signal.dlsim by an m-sequence, with noise and a slow drift.

Tolerances come from the noise: the cyclic estimator's tap noise is sqrt(2 / (M + 1)) sigma / a
per period (docs/noise.md), so the mean over P periods is sigma_h = that / sqrt(P); every tap
must be within 5 sigma_h of the known response (M taps: a false failure about once in 10^4
records), and the 95 % bounds must hold the known response on at least 85 % of the taps
(binomial spread 1.4 % at M = 255)."""

from __future__ import annotations

import dataclasses
import hashlib
import json
import re
import sys
from pathlib import Path

import numpy as np
import pandas as pd
import pyarrow as pa
import pyarrow.parquet as pq
import pytest
import scipy.io
from conftest import interrupt_when
from scipy import signal

from probing.cli import main as cli_main
from probing.core.prbs import MAX_ORDER, MIN_ORDER, mls
from probing.experiment.recorded.analyze import AnalysisRequest, _deviations

ORDER, M, AMPLITUDE, SIGMA, DT_S = 8, 255, 0.5, 0.01, 0.05
SYSTEM = (  # a lightly damped second-order discrete system (poles 0.85 +- 0.3j) plus a D term
    np.array([[1.7, -0.8125], [1.0, 0.0]]),
    np.array([[1.0], [0.0]]),
    np.array([[0.3, -0.1]]),
    np.array([[0.05]]),
    DT_S,
)


def pulse_response(spb: int) -> np.ndarray:
    """The known response to a one-bit pulse of unit amplitude, at the end of each bit."""
    u = np.zeros(M * spb)
    u[:spb] = 1.0
    y = signal.dlsim(SYSTEM, u)[1][:, 0]
    return y[spb - 1 :: spb]


def make_record(
    spb: int = 1,
    lead_bits: int = 40,
    lead_samples: int = 0,
    tail_samples: int = 0,
    scipy_sequence: bool = True,
    seed: int = 0,
) -> pd.DataFrame:
    """6 periods and a bit, recorded from probe bit ``lead_bits`` (mid-sequence) and mid-bit
    (``lead_samples`` of the bit before), ending ``tail_samples`` into an unfinished bit."""
    seq = 2.0 * signal.max_len_seq(ORDER)[0] - 1.0 if scipy_sequence else mls(ORDER)
    u = 1.5 + AMPLITUDE * np.repeat(np.tile(seq, 8), spb)
    y = signal.dlsim(SYSTEM, u - 1.5)[1][:, 0]
    start = lead_bits * spb - lead_samples
    stop = start + lead_samples + (6 * M + 1) * spb + tail_samples
    t = np.arange(stop - start) * DT_S
    drift = 0.2 + 0.02 * t  # an offset and a slow drift, 25 sigma over the record
    noise = SIGMA * np.random.default_rng(seed).standard_normal(t.size)
    return pd.DataFrame(
        {
            "t_s": t,
            "u_deg": u[start:stop],
            "y": y[start:stop] + drift + noise,
            "ref": drift,
        }
    )


def write(frame: pd.DataFrame, path: Path) -> Path:
    if path.suffix == ".csv":
        frame.to_csv(path, index=False, float_format="%.17g")
    elif path.suffix == ".parquet":
        pq.write_table(pa.Table.from_pandas(frame, preserve_index=False), path)
    else:
        scipy.io.savemat(path, {c: frame[c].to_numpy()[:, None] for c in frame})
    return path


def analyze(path: Path, out: Path, *extra: str) -> int:
    return cli_main(
        [
            "analyze", str(path), "--input", "u_deg", "--output", "y", "--time", "t_s",
            "--order", str(ORDER), "--bit-duration-s", str(DT_S * int(extra[0]) if extra and
            extra[0].isdigit() else DT_S), "--out", str(out),
            *(e for e in extra if not e.isdigit()),
        ]
    )  # fmt: skip


def bounds(out: Path) -> pd.DataFrame:
    return pq.read_table(out / "bounds.parquet").to_pandas()


def sigma_h(periods: int) -> float:
    return np.sqrt(2.0 / (M + 1)) * SIGMA / AMPLITUDE / np.sqrt(periods)


def check_estimate(out: Path, expected: np.ndarray) -> None:
    b = bounds(out)
    periods = json.loads(pq.read_metadata(out / "bounds.parquet").metadata[b"probing.confidence"])
    tol = 5 * sigma_h(periods["dof"] + 1)
    err = b.h_est.to_numpy() - expected
    assert np.max(np.abs(err)) < tol, (np.max(np.abs(err)), tol)
    inside = (b.h_low.to_numpy() <= expected) & (expected <= b.h_high.to_numpy())
    assert inside.mean() >= 0.85, inside.mean()


@pytest.mark.parametrize("suffix", [".csv", ".parquet", ".mat"])
def test_every_format_gives_the_known_response(tmp_path: Path, suffix: str) -> None:
    """Drift removed by the joint fit, the constant pinned by the settled tail: the known
    response itself; with the reference column, the response itself too."""
    path = write(make_record(), tmp_path / f"rec{suffix}")
    h = pulse_response(1)
    assert analyze(path, tmp_path / "detrend") == 0
    check_estimate(tmp_path / "detrend", h)
    assert analyze(path, tmp_path / "ref", "--reference", "ref") == 0
    check_estimate(tmp_path / "ref", h)
    table = pq.read_table(tmp_path / "ref" / "probing.parquet")
    assert table.num_rows == 5 * M  # 6 periods and a bit from mid-sequence: 5 whole ones
    assert set(table.column("period").to_pylist()) == set(range(5))


def test_same_estimate_from_each_format(tmp_path: Path) -> None:
    frame = make_record(seed=3)
    got = []
    for suffix in (".csv", ".parquet", ".mat"):
        assert analyze(write(frame, tmp_path / f"r{suffix}"), tmp_path / suffix) == 0
        got.append(bounds(tmp_path / suffix).h_est.to_numpy())
    np.testing.assert_allclose(got[0], got[1], rtol=0, atol=1e-12)
    np.testing.assert_allclose(got[0], got[2], rtol=0, atol=1e-12)


def test_mid_bit_start_several_samples_per_bit_and_project_sequence(tmp_path: Path) -> None:
    """Three samples per bit, the record starting one sample into a bit and ending inside
    one; the project's own m-sequence (the scipy one inverted) is accepted as well."""
    frame = make_record(spb=3, lead_bits=100, lead_samples=1, tail_samples=2, scipy_sequence=False)
    path = write(frame, tmp_path / "rec.csv")
    assert analyze(path, tmp_path / "out", "3", "--reference", "ref") == 0
    check_estimate(tmp_path / "out", pulse_response(3))
    meta = json.loads(pq.read_metadata(tmp_path / "out" / "probing.parquet").metadata[
        b"probing.analysis"
    ])  # fmt: skip
    assert meta["bit_offset_samples"] == 1 and meta["samples_per_bit"] == 3
    assert meta["sequence_shift_bits"] == 100 and meta["sign"] == 1
    assert meta["first_sample"] == 1 + 3 * (M - 100)
    assert meta["periods_used"] == 5


def test_drift_none_is_biased_by_the_drift(tmp_path: Path) -> None:
    """The trend the joint fit removes is what ``--drift none`` leaves in the estimate."""
    path = write(make_record(), tmp_path / "rec.parquet")
    h = pulse_response(1)
    assert analyze(path, tmp_path / "none", "--drift", "none") == 0
    err = bounds(tmp_path / "none").h_est.to_numpy() - h
    assert np.max(np.abs(err)) > 10 * sigma_h(5)


def test_provenance_sha256_and_same_bytes(tmp_path: Path) -> None:
    path = write(make_record(), tmp_path / "rec.csv")
    assert analyze(path, tmp_path / "a") == 0 and analyze(path, tmp_path / "b") == 0
    sha = hashlib.sha256(path.read_bytes()).hexdigest()
    for name in ("probing.parquet", "bounds.parquet"):
        meta = pq.read_metadata(tmp_path / "a" / name).metadata
        assert json.loads(meta[b"probing.input"]) == {"file": "rec.csv", "sha256": sha}
        assert json.loads(meta[b"probing.confidence"])["level"] == 0.95
    for name in ("probing.parquet", "bounds.parquet", "pulse_response.png"):
        assert (tmp_path / "a" / name).read_bytes() == (tmp_path / "b" / name).read_bytes()


def _gap(f: pd.DataFrame) -> pd.DataFrame:
    return f.drop(index=300).reset_index(drop=True)


def _nan(f: pd.DataFrame) -> pd.DataFrame:
    f.loc[500, "y"] = np.nan
    return f


def _backwards(f: pd.DataFrame) -> pd.DataFrame:
    f.loc[[200, 201], "t_s"] = f.loc[[201, 200], "t_s"].to_numpy()
    return f


def _text(f: pd.DataFrame) -> pd.DataFrame:
    return f.assign(y=f.y.astype(str))  # numbers written as text: not a column of numbers


def _not_msequence(f: pd.DataFrame) -> pd.DataFrame:
    f.loc[700, "u_deg"] = 3.0 - f.loc[700, "u_deg"]  # one bit flipped
    return f


@pytest.mark.parametrize(
    ("spoil", "suffix", "extra", "needle"),
    [
        (_gap, ".csv", (), "not uniform at row 300"),
        (_nan, ".parquet", (), "column y has NaN"),
        (_backwards, ".mat", (), "time is not uniform at row 200 (it steps by 0.1 s"),
        (_not_msequence, ".csv", (), "not an m-sequence of order 8"),
        (_text, ".parquet", (), "column y holds text, not numbers"),
        (lambda f: f.iloc[:0], ".csv", (), "rec.csv: it holds no rows"),
        (lambda f: f, ".csv", ("--output", "pitch"), "no column pitch"),
        (lambda f: f, ".txt", (), "unknown file type"),
    ],
)
def test_bad_input_one_line_exit_2_nothing_written(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], spoil, suffix, extra, needle
) -> None:
    frame = spoil(make_record())
    path = tmp_path / f"rec{suffix}"
    write(frame, path) if suffix != ".txt" else frame.to_csv(path, index=False)
    out = tmp_path / "out"
    capsys.readouterr()
    assert analyze(path, out, *extra) == 2
    err = capsys.readouterr().err.splitlines()
    assert len(err) == 1 and err[0].startswith("probing: error: ") and needle in err[0], err
    assert not out.exists()


@pytest.mark.parametrize("suffix", [".csv", ".parquet", ".mat"])
def test_an_empty_record_is_one_line(tmp_path: Path, suffix: str) -> None:
    """No rows, the step given (no time column to count them): RecordError naming the file,
    nothing written; was numpy's ValueError of a minimum of nothing."""
    import probing
    from probing.experiment.recorded.record import RecordError

    path = write(make_record().iloc[:0], tmp_path / f"rec{suffix}")
    with pytest.raises(RecordError, match=rf"^{re.escape(str(path))}: it holds no rows$"):
        probing.analyze(
            path, input="u_deg", outputs=["y"], order=ORDER, bit_duration_s=DT_S, dt_s=DT_S,
            scratch=tmp_path / "scratch",
        )  # fmt: skip
    assert not (tmp_path / "scratch").exists()


@pytest.mark.parametrize("drift", ["none", "detrend"])
def test_each_output_loses_a_constant_of_its_own(drift: str) -> None:
    """Drift removal works output by output: with two outputs 1000 apart, each one's
    deviations are its own samples less a constant (``--drift none``: nothing else) and the
    same as when it is analysed alone, not shifted by the other's level."""
    m = 31
    rng = np.random.default_rng(7)
    t = np.arange(4 * m)
    cols = {"a": 1000.0 + 0.01 * t + rng.normal(size=t.size), "b": -5.0 + rng.normal(size=t.size)}
    req = AnalysisRequest(Path("rec.csv"), "u", ("a", "b"), 5, 0.01, dt_s=0.01, drift=drift)
    both = _deviations(req, cols, m)
    for j, name in enumerate(("a", "b")):
        alone = _deviations(dataclasses.replace(req, outputs=(name,)), cols, m)
        np.testing.assert_allclose(both[:, j], alone[:, 0], rtol=0, atol=1e-9)
        if drift == "none":
            removed = cols[name] - both[:, j]
            np.testing.assert_allclose(removed, removed[0], rtol=0, atol=1e-9)
            assert abs(both[:, j].mean()) < 1e-9  # its own mean: no level left


@pytest.mark.parametrize(
    ("order", "refused"),
    [("-3", True), ("0", True), (str(MIN_ORDER - 1), True), (str(MIN_ORDER), False),
     (str(MAX_ORDER), False), (str(MAX_ORDER + 1), True), ("eight", True), ("7.0", True)],
)  # fmt: skip
def test_order_outside_the_supported_range_is_refused_before_the_record_is_read(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], order: str, refused: bool
) -> None:
    """The orders of probing.core.prbs (MIN_ORDER to MAX_ORDER) pass the API's check, which
    the command line names by its option: a record that is not that m-sequence is then
    refused by the analysis, with its own message."""
    path = write(make_record(), tmp_path / "rec.csv")
    out = tmp_path / "out"
    capsys.readouterr()
    argv = ["analyze", str(path), "--input", "u_deg", "--output", "y", "--time", "t_s",
            "--order", order, "--bit-duration-s", str(DT_S), "--out", str(out)]  # fmt: skip
    assert cli_main(argv) == 2
    err = capsys.readouterr().err.splitlines()
    assert len(err) == 1 and err[0].startswith("probing: error: "), err
    if refused:
        assert f"--order: must be an integer from {MIN_ORDER} to {MAX_ORDER}" in err[0], err
    else:
        assert "not an m-sequence" in err[0], err
    assert not out.exists()


ANALYZE_FILES = ("bounds.parquet", "probing.parquet", "pulse_response.png")


@pytest.mark.slow
@pytest.mark.parametrize("delay_s", [-1.0, 0.0, 0.05, 0.15, 0.3, 0.6, 1.0, 1.5])
def test_an_interrupt_at_any_moment_leaves_nothing(tmp_path: Path, delay_s: float) -> None:
    """Ctrl-C while the estimates, the bounds or the figure are written (or after): exit 130
    with no output folder, or the command had finished (exit 0) with all three files."""
    path = write(make_record(spb=40), tmp_path / "rec.csv")
    out = tmp_path / "out"
    cmd = [sys.executable, "-m", "probing", "analyze", str(path), "--input", "u_deg",
           "--output", "y", "--time", "t_s", "--order", str(ORDER), "--bit-duration-s",
           str(40 * DT_S), "--out", str(out)]  # fmt: skip
    res = interrupt_when(cmd, out, delay_s)
    assert "Traceback" not in res.stderr, res.stderr
    if res.returncode == 130:
        assert res.stderr.splitlines()[-1] == "probing: error: interrupted"
        assert not out.exists(), sorted(p.name for p in out.iterdir())
    else:
        assert res.returncode == 0, res.stderr
        assert sorted(p.name for p in out.iterdir()) == list(ANALYZE_FILES)


def _analyze_with_time(path: Path, out: Path, time_col: str, bit_s: float) -> int:
    return cli_main(
        ["analyze", str(path), "--input", "u_deg", "--output", "y", "--time", time_col,
         "--order", str(ORDER), "--bit-duration-s", str(bit_s), "--out", str(out)]
    )  # fmt: skip


@pytest.mark.parametrize(
    ("column", "values", "needle"),
    [
        ("time_ms", lambda t: t * 1000.0, "time_ms looks like milliseconds"),
        ("t_us", lambda t: t * 1e6, "t_us looks like microseconds"),
        ("unix_s", lambda t: 1.7e9 + t, "looks like Unix time"),
    ],
)
def test_a_time_column_not_in_seconds_from_the_start_is_refused_with_what_to_do(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], column, values, needle
) -> None:
    """A time column in milliseconds labelled 5040 "seconds"; Unix time failed on the float
    jitter of its step (2e-7 s at 1.7e9 s): one line saying what to do, exit 2."""
    frame = make_record()
    frame[column] = values(frame.pop("t_s"))
    path = write(frame, tmp_path / "rec.csv")
    capsys.readouterr()
    assert _analyze_with_time(path, tmp_path / "out", column, DT_S * 1000) == 2
    err = capsys.readouterr().err.splitlines()
    assert len(err) == 1 and needle in err[0], err
    assert "--dt-s" in err[0] and "seconds from the record's start" in err[0], err
    assert not (tmp_path / "out").exists()


@pytest.mark.parametrize("suffix", [".csv", ".parquet"])
def test_a_uniform_datetime_column_is_seconds_from_the_first_sample(
    tmp_path: Path, suffix: str
) -> None:
    """Date-times (a Parquet timestamp, ISO text in a CSV) at a uniform step are read as
    seconds from the first sample: the same estimate as the seconds column."""
    frame = make_record()
    assert analyze(write(frame, tmp_path / "s.csv"), tmp_path / "seconds") == 0
    start = pd.Timestamp("2024-05-01T12:00:00")
    frame["when"] = start + pd.to_timedelta(np.round(frame.pop("t_s") * 1e3), unit="ms")
    path = write(frame, tmp_path / f"d{suffix}")
    assert _analyze_with_time(path, tmp_path / "dates", "when", DT_S) == 0
    np.testing.assert_array_equal(
        bounds(tmp_path / "dates").h_est.to_numpy(), bounds(tmp_path / "seconds").h_est.to_numpy()
    )
    meta = json.loads(pq.read_metadata(tmp_path / "dates" / "probing.parquet").metadata[
        b"probing.analysis"
    ])  # fmt: skip
    assert meta["dt_s"] == pytest.approx(DT_S, rel=1e-12)


def test_a_datetime_column_with_a_gap_is_refused_in_seconds(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    frame = make_record().drop(index=300).reset_index(drop=True)
    start = pd.Timestamp("2024-05-01T12:00:00")
    frame["when"] = start + pd.to_timedelta(np.round(frame.pop("t_s") * 1e3), unit="ms")
    path = write(frame, tmp_path / "d.parquet")
    capsys.readouterr()
    assert _analyze_with_time(path, tmp_path / "out", "when", DT_S) == 2
    err = capsys.readouterr().err
    assert "not uniform at row 300 (it steps by 0.1 s, not 0.05 s)" in err, err
