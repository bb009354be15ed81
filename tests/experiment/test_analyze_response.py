"""``probing analyze`` gives the pulse response itself where it settles within the period.

Truth: ``scipy.signal.dimpulse`` of made-up discrete systems (several orders, either sign),
driven by ``scipy.signal.max_len_seq`` through ``scipy.signal.dlsim``, with and without a
slow drift, and small white noise.  The goal is a relative L2 error within 1 %; the noise
alone contributes sqrt(2 / P) sigma / a / ||h|| (the cyclic estimator's tap noise summed over
M taps, docs/noise.md), at most 0.1 % here, so 1 % is the estimate's bias, not its noise.
The zero-mean convention (h - sum(h) / M) misses it by 12-23 % on each of them."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pandas as pd
import pyarrow.parquet as pq
import pytest
from scipy import signal

from probing.cli import main as cli_main

ORDER, M, AMPLITUDE, DT_S, SIGMA, PERIODS = 8, 255, 0.5, 0.02, 1e-4, 6

SYSTEMS = {  # (numerator, denominator) in z, dt DT_S: settled well within the period
    "first order": ([0.3], [1.0, -0.85]),
    "second order, negative": ([-0.2, 0.1], [1.0, -1.6, 0.7225]),
    "third order": ([0.05, 0.02, 0.01], [1.0, -1.8, 1.05, -0.2]),
}


def record(num, den, drift: bool, seed: int = 0) -> pd.DataFrame:
    seq = 2.0 * signal.max_len_seq(ORDER)[0] - 1.0
    u = AMPLITUDE * np.tile(seq, PERIODS + 3)
    y = signal.dlsim((num, den, DT_S), u)[1][:, 0]
    start = 2 * M + 17  # the response in its periodic steady state, mid-sequence
    t = np.arange(y.size - start) * DT_S
    y = y[start:] + SIGMA * np.random.default_rng(seed).standard_normal(t.size)
    if drift:
        y = y + 0.5 - 0.02 * t  # an offset and a slow drift, 100 times the noise per second
    return pd.DataFrame({"time_s": t, "elevator_deg": u[start:], "q_rad_s": y})


def truth(num, den) -> np.ndarray:
    return signal.dimpulse((num, den, DT_S), n=M)[1][0][:, 0]


def analyze(path: Path, out: Path, *extra: str) -> int:
    return cli_main(
        [
            "analyze", str(path), "--input", "elevator_deg", "--output", "q_rad_s", "--time",
            "time_s", "--order", str(ORDER), "--bit-duration-s", str(DT_S), "--out", str(out),
            *extra,
        ]
    )  # fmt: skip


def rel(err: np.ndarray, h: np.ndarray) -> float:
    return float(np.linalg.norm(err) / np.linalg.norm(h))


@pytest.mark.parametrize("name", list(SYSTEMS))
@pytest.mark.parametrize("drift", [False, True])
def test_the_response_itself_within_one_percent(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], name: str, drift: bool
) -> None:
    num, den = SYSTEMS[name]
    h = truth(num, den)
    assert np.abs(h[M // 10 :]).max() < 0.05 * np.abs(h).max()  # settled within a tenth
    assert np.sqrt(2 / (PERIODS - 1)) * SIGMA / AMPLITUDE / np.linalg.norm(h) < 1e-3
    path = tmp_path / "rec.csv"
    record(num, den, drift).to_csv(path, index=False, float_format="%.17g")
    capsys.readouterr()
    assert analyze(path, tmp_path / "out", "--drift", "detrend" if drift else "none") == 0
    said = capsys.readouterr().out
    assert "q_rad_s: h_est is the response: the tail from lag" in said, said
    est = pq.read_table(tmp_path / "out" / "bounds.parquet").column("h_est").to_numpy()
    assert rel(est - h, h) < 0.01, rel(est - h, h)
    assert rel(h - h.sum() / M - h, h) > 0.1  # what the zero-mean convention would miss
    meta = pq.read_metadata(tmp_path / "out" / "probing.parquet").metadata
    conv = json.loads(meta[b"probing.convention"])
    assert conv["h_est"] == {"q_rad_s": "settled tail"}
    assert conv["tail"]["from_tap"] == M - 64 and conv["tail"]["taps"] == 64
    units = json.loads(meta[b"probing.units"])
    assert units["h_est"] == {"q_rad_s": "rad/s/deg"}


def test_a_response_that_has_not_settled_keeps_the_zero_mean_and_says_so(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """A pole at 0.995: 38 % of the response is left at the tail's start; the estimate is
    the folded response less its mean, and the line, the files and the figure say so."""
    num, den = [0.01], [1.0, -0.995]
    path = tmp_path / "rec.csv"
    record(num, den, drift=True).to_csv(path, index=False, float_format="%.17g")
    capsys.readouterr()
    assert analyze(path, tmp_path / "out") == 0
    said = capsys.readouterr().out
    assert "q_rad_s: the tail from lag 3.82 s has not settled" in said, said
    assert "h_est is the response less sum(h)/M" in said
    long = signal.dimpulse((num, den, DT_S), n=40 * M)[1][0][:, 0]
    folded = long.reshape(40, M).sum(axis=0)
    est = pq.read_table(tmp_path / "out" / "bounds.parquet").column("h_est").to_numpy()
    assert rel(est - (folded - folded.sum() / M), folded) < 0.01
    for name in ("probing.parquet", "bounds.parquet"):
        conv = json.loads(pq.read_metadata(tmp_path / "out" / name).metadata[b"probing.convention"])
        assert conv["h_est"] == {"q_rad_s": "zero mean"}
        assert conv["tail"]["f_statistic"]["q_rad_s"] > conv["tail"]["f_threshold"]["q_rad_s"]


def test_settled_after_moves_the_tail_and_is_checked(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    num, den = SYSTEMS["first order"]
    path = tmp_path / "rec.csv"
    record(num, den, drift=False).to_csv(path, index=False, float_format="%.17g")
    assert analyze(path, tmp_path / "a", "--settled-after-s", "2") == 0
    conv = json.loads(
        pq.read_metadata(tmp_path / "a" / "bounds.parquet").metadata[b"probing.convention"]
    )
    assert conv["tail"]["from_tap"] == 100 and conv["tail"]["taps"] == M - 100
    capsys.readouterr()
    # the tail must keep 3 taps: from 5.04 s (tap 252) it does, from 5.06 s (tap 253) not
    assert analyze(path, tmp_path / "b", "--settled-after-s", "5.04") == 0
    assert analyze(path, tmp_path / "c", "--settled-after-s", "5.06") == 2
    err = capsys.readouterr().err.splitlines()
    assert len(err) == 1 and "--settled-after-s 5.06" in err[0] and "too short" in err[0]
    assert not (tmp_path / "c").exists()
