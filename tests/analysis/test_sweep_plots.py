"""Sweep figures (``probing plot sweep``) from small synthetic sweep folders: no simulation.

The figures are checked by what they show: the data read back from their axes must be the
summary's numbers and the closed-form theory, the failed points marked where they are.
"""

from __future__ import annotations

import json
import math
from pathlib import Path
from typing import Any

import matplotlib.pyplot as plt
import numpy as np
import pandas as pd
import pytest
from conftest import base_scenario

from probing.analysis import sweep_plots
from probing.analysis.figure_checks import figure_problems
from probing.analysis.sweep_plots import (
    classify,
    load_sweep_data,
    plot_sweep,
    sweep_figure,
    theory_curve,
)
from probing.cli import main as cli_main
from probing.experiment.scenario import parse_scenario

A = 0.005  # probe amplitude of the base scenario, deg
PNG_MAGIC = b"\x89PNG\r\n\x1a\n"
BASE: dict[str, Any] = base_scenario(
    {"probe.amplitude_deg": A, "output.channels": ["theta_rad", "q_rad_s"]},
    name="base",
    disturbance={"turbulence": "none", "seed": 0},
)


@pytest.fixture(autouse=True)
def _fast(monkeypatch):
    """The tests check files, not pixels: low resolution, PNG only unless a test asks."""
    monkeypatch.setattr(sweep_plots, "DPI", 40)
    monkeypatch.setattr(sweep_plots, "FORMATS", ("png",))


def _toml_value(v: Any) -> str:
    return json.dumps(v)


def _write_sweep(
    folder: Path,
    name: str,
    *,
    grid: dict[str, list[Any]] | None = None,
    zipped: dict[str, list[Any]] | None = None,
    fixed: dict[str, Any] | None = None,
    points: list[dict[str, Any]],
    rows: list[dict[str, Any]],
    description: str = "",
) -> Path:
    """A sweep folder with sweep.json and summary.parquet written by hand.

    ``points`` are the varied values per point; ``rows`` the summary columns per point
    (defaults: done, gain 1, everything else NaN).
    """
    grid, zipped, fixed = grid or {}, zipped or {}, fixed or {}
    lines = [f'name = "{name}"', 'base = "base.toml"']
    if description:
        lines.append(f'description = "{description}"')
    for table, entries in (("fixed", fixed), ("grid", grid), ("zip", zipped)):
        if entries:
            lines.append(f"[{table}]")
            lines += [f'"{k}" = {_toml_value(v)}' for k, v in entries.items()]
    fields = list(grid) + list(zipped)
    sweep_dir = folder / name
    sweep_dir.mkdir(parents=True)
    manifest = {
        "name": name,
        "source": f"scenarios/sweeps/{name}.toml",
        "sweep_toml": "\n".join(lines) + "\n",
        "base": BASE,
        "fields": fields,
        "points": [
            {"index": i, "point_id": f"p{i:04d}", "reference_id": "ref", "values": v}
            for i, v in enumerate(points)
        ],
    }
    (sweep_dir / "sweep.json").write_text(json.dumps(manifest))
    records = []
    for i, (values, row) in enumerate(zip(points, rows, strict=True)):
        rec: dict[str, Any] = {"index": i, "point_id": f"p{i:04d}", **values}
        rec.update(
            status="done",
            message="",
            channel="theta_rad",
            predicted_gain=1.0,
            predicted_offset_deg=0.0,
            rate_ratio=math.nan,
            measured_gain=1.0,
            shape_error=1e-7,
            h_rms=1e-3,
            h_stderr=1e-4,
            h_stderr_naive=0.0,
            predicted_z_stderr=0.0,
            predicted_h_stderr=0.0,
            predicted_gain_stderr=0.0,
            predicted_h_bias=0.0,
            wall_s=1.0,
            steps_simulated=4088,
            reference_id="ref",
        )
        rec.update(row)
        if rec["status"] != "done":
            for col in ("measured_gain", "shape_error", "h_rms", "h_stderr"):
                rec[col] = math.nan
            rec.update(message="trim failed: Trim Failed", steps_simulated=0)
        records.append(rec)
    pd.DataFrame(records).to_parquet(sweep_dir / "summary.parquet")
    return sweep_dir


# ------------------------------------------------------------------ the five kinds
def _backlash(tmp: Path, failed: set[int]) -> Path:
    widths = [round(w, 6) for w in np.linspace(0.0, 0.011, 12)]
    rows = []
    for i, w in enumerate(widths):
        g = max(1 - w / (2 * A), 0.0)
        shape = 0.0 if w == 0 else (math.inf if g == 0 else 2e-8 * i)
        status = "failed" if i in failed else "done"
        rows.append(
            {"predicted_gain": g, "measured_gain": g, "shape_error": shape, "status": status}
        )
    return _write_sweep(
        tmp,
        "backlash-width",
        grid={"nonlinearity.type": ["backlash"], "nonlinearity.width_deg": widths},
        points=[{"nonlinearity.type": "backlash", "nonlinearity.width_deg": w} for w in widths],
        rows=rows,
        description="Backlash of width w: predicted gain 1 - w/(2a)",
    )


def _hysteresis(tmp: Path, failed: set[int]) -> Path:
    ws = [0.0, 0.002, 0.004, 0.005, 0.006]
    points = [
        {
            "nonlinearity.type": "hysteresis_relay",
            "nonlinearity.low_deg": -A / 2,
            "nonlinearity.high_deg": A / 2,
            "nonlinearity.lower_threshold_deg": -w,
            "nonlinearity.upper_threshold_deg": w,
        }
        for w in ws
    ]
    rows = [
        {
            "predicted_gain": 0.5 if w < A else 0.0,
            "predicted_offset_deg": 0.0 if w < A else -A / 2,
            "measured_gain": 0.5 if w < A else 24.6,  # stuck relay: the step leaks into h
            "shape_error": 1e-7 if w < A else 0.02,
            "status": "failed" if i in failed else "done",
        }
        for i, w in enumerate(ws)
    ]
    return _write_sweep(
        tmp,
        "hysteresis-width",
        grid={
            "nonlinearity.type": ["hysteresis_relay"],
            "nonlinearity.low_deg": [-A / 2],
            "nonlinearity.high_deg": [A / 2],
        },
        zipped={
            "nonlinearity.lower_threshold_deg": [-w for w in ws],
            "nonlinearity.upper_threshold_deg": ws,
        },
        points=points,
        rows=rows,
    )


def _rate_limit(tmp: Path, failed: set[int]) -> Path:
    t0 = 0.04
    rates = [0.0625, 0.125, 0.25, 0.5, 1.0]
    rows = []
    for i, r in enumerate(rates):
        ratio = r / (2 * A / t0)
        rows.append(
            {
                "rate_ratio": ratio,
                "predicted_gain": 1.0 if ratio >= 1 else math.nan,
                "predicted_offset_deg": 0.0 if ratio >= 1 else math.nan,
                "measured_gain": 1.0 + 0.2 * max(1 - ratio, 0),
                "shape_error": 0.0 if ratio >= 4 else 1e-3 / ratio,
                "status": "failed" if i in failed else "done",
            }
        )
    return _write_sweep(
        tmp,
        "rate-limit",
        fixed={"probe.bit_duration_s": t0},
        grid={"nonlinearity.type": ["rate_limit"], "nonlinearity.rate_deg_s": rates},
        points=[{"nonlinearity.type": "rate_limit", "nonlinearity.rate_deg_s": r} for r in rates],
        rows=rows,
    )


def _noise(tmp: Path, failed: set[int]) -> Path:
    amps = [0.005, 0.01]
    sigmas = [0.0, 1e-5, 1e-4]
    points, rows = [], []
    m, p = 511, 6
    for a in amps:
        for s in sigmas:
            i = len(points)
            naive = s / (a * math.sqrt(m * p))
            points.append({"probe.amplitude_deg": a, "disturbance.sensor_noise.q_rad_s": s})
            rows.append(
                {
                    "channel": "q_rad_s",
                    "h_stderr_naive": naive,
                    "predicted_h_stderr": 6.9 * naive,
                    "h_stderr": 16.6 * naive + 5e-5,
                    "status": "failed" if i in failed else "done",
                }
            )
    return _write_sweep(
        tmp,
        "amplitude-noise",
        fixed={"output.channels": ["q_rad_s", "theta_rad"]},
        grid={"probe.amplitude_deg": amps, "disturbance.sensor_noise.q_rad_s": sigmas},
        points=points,
        rows=rows,
    )


def _flight_grid(tmp: Path, failed: set[int]) -> Path:
    alts, speeds = [2000, 20000, 40000], [180, 280, 360]
    points, rows = [], []
    for alt in alts:
        for v in speeds:
            i = len(points)
            points.append({"condition.altitude_ft": alt, "condition.speed_kcas": v})
            rows.append(
                {
                    "predicted_gain": 2 / 3,
                    "measured_gain": 2 / 3 * (1 + 1e-6 * (i - 4)),
                    "shape_error": 1e-7 * (i + 1) if i != 4 else 0.0,
                    "status": "failed" if i in failed else "done",
                }
            )
    return _write_sweep(
        tmp,
        "flight-grid",
        fixed={
            "nonlinearity.type": "deadband",
            "nonlinearity.lower_deg": -A / 3,
            "nonlinearity.upper_deg": A / 3,
        },
        grid={"condition.altitude_ft": alts, "condition.speed_kcas": speeds},
        points=points,
        rows=rows,
    )


def _other(tmp: Path, failed: set[int]) -> Path:
    orders = [7, 8, 9]
    return _write_sweep(
        tmp,
        "order",
        grid={"probe.order": orders},
        points=[{"probe.order": o} for o in orders],
        rows=[
            {"measured_gain": 1.0 - 1e-3 * i, "status": "failed" if i in failed else "done"}
            for i in range(len(orders))
        ],
    )


KINDS = {
    "backlash": (_backlash, "nonlinearity", {3}),
    "hysteresis": (_hysteresis, "nonlinearity", {1}),
    "rate_limit": (_rate_limit, "rate_limit", {0}),
    "noise": (_noise, "noise", {2}),
    "flight_grid": (_flight_grid, "flight_grid", {0, 3, 8}),
    "other": (_other, "other", {1}),
}


def _assert_png(path: Path) -> None:
    data = path.read_bytes()
    assert len(data) > 1000 and data.startswith(PNG_MAGIC)


def _xy(ax: Any, label: str) -> tuple[np.ndarray, np.ndarray]:
    """x and y of the line drawn with this legend label (exactly one must exist)."""
    lines = [ln for ln in ax.get_lines() if ln.get_label() == label]
    assert len(lines) == 1, (label, [ln.get_label() for ln in ax.get_lines()])
    return (np.asarray(lines[0].get_xdata(), float), np.asarray(lines[0].get_ydata(), float))


def _failed_x(ax: Any, n: int) -> np.ndarray:
    return _xy(ax, f"failed (trim/divergence): {n}")[0]


def _figure(folder: Path) -> tuple[Any, pd.DataFrame]:
    """The sweep's figure, which reads: no legend over data (the rate limit's and the noise
    figure's lay over their points), no unnamed curve, no text over another, every number
    legible on its cell (figure_problems)."""
    data = load_sweep_data(folder)
    fig = sweep_figure(data)
    assert figure_problems(fig) == []
    return fig, data.summary


def _done(summary: pd.DataFrame) -> np.ndarray:
    return (summary["status"] == "done").to_numpy()


def _assert_failed_marked(ax: Any, x: np.ndarray, summary: pd.DataFrame) -> None:
    """The failed points, and only they, marked at their x (none: no marker at all)."""
    failed = ~_done(summary)
    if failed.any():
        np.testing.assert_allclose(_failed_x(ax, int(failed.sum())), x[failed])
    else:
        assert not any(ln.get_label().startswith("failed") for ln in ax.get_lines())


# What each kind's figure shows, read from its axes and compared with the summary's numbers.
def _shows_backlash(fig: Any, summary: pd.DataFrame) -> None:
    ax1 = fig.axes[0]
    width_over_a = summary["nonlinearity.width_deg"].to_numpy() / A
    x, y = _xy(ax1, "predicted a~/a, eq. (10)")
    np.testing.assert_allclose(y, np.clip(1 - x / 2, 0, None), atol=1e-12)
    assert x.min() == 0 and x.max() == pytest.approx(width_over_a.max())
    x, y = _xy(ax1, "measured gain g")
    done = _done(summary)
    np.testing.assert_allclose(x, width_over_a[done])
    np.testing.assert_allclose(y, summary["measured_gain"][done])
    _assert_failed_marked(ax1, width_over_a, summary)


def _shows_hysteresis(fig: Any, summary: pd.DataFrame) -> None:
    ax1 = fig.axes[0]
    x, y = _xy(ax1, "predicted a~/a, eq. (10)")  # x = S+/a; the relay switches iff a > S+
    np.testing.assert_array_equal(y, np.where(x < 1, 0.5, 0.0))
    x, y = _xy(ax1, "measured gain g")  # the stuck points (b~ != 0) are drawn apart
    thresholds = summary["nonlinearity.upper_threshold_deg"].to_numpy() / A
    plain = (thresholds < 1) & _done(summary)
    np.testing.assert_allclose(x, thresholds[plain])
    np.testing.assert_allclose(y, summary["measured_gain"][plain])
    _assert_failed_marked(ax1, thresholds, summary)


def _shows_rate_limit(fig: Any, summary: pd.DataFrame) -> None:
    ax1 = fig.axes[0]
    x, y = _xy(ax1, "measured gain g")
    ratio = summary["rate_ratio"].to_numpy()
    np.testing.assert_allclose(x, ratio)  # failed points are NaN in the summary
    np.testing.assert_allclose(y, summary["measured_gain"], equal_nan=True)
    np.testing.assert_allclose(ratio, [0.25, 0.5, 1, 2, 4])  # r / (2a/t0) with t0 = 0.04 s
    _assert_failed_marked(ax1, ratio, summary)


def _shows_noise(fig: Any, summary: pd.DataFrame) -> None:
    ax1, ax2 = fig.axes[:2]
    for a in (0.005, 0.01):
        rows = summary[(summary["probe.amplitude_deg"] == a) & _done(summary)]
        rows = rows[rows["h_stderr_naive"] > 0]
        x, y = _xy(ax1, f"a = {a:g} deg")
        np.testing.assert_allclose(x, rows["h_stderr_naive"])
        np.testing.assert_allclose(y, rows["h_stderr"])
        x, y = _xy(ax2, f"a = {a:g} deg")
        np.testing.assert_allclose(y, rows["h_stderr"] / rows["predicted_h_stderr"])


def _shows_flight_grid(fig: Any, summary: pd.DataFrame) -> None:
    ax1 = fig.axes[0]  # measured / predicted gain (the colour bars come after the panels)
    grid = np.ma.getdata(ax1.collections[0].get_array()).reshape(3, 3)
    mask = np.ma.getmaskarray(ax1.collections[0].get_array()).reshape(3, 3)
    expected = (summary["measured_gain"] / summary["predicted_gain"]).to_numpy().reshape(3, 3)
    np.testing.assert_array_equal(mask.reshape(-1), ~_done(summary))
    np.testing.assert_allclose(grid[~mask], expected[~mask], rtol=1e-12)


def _shows_other(fig: Any, summary: pd.DataFrame) -> None:
    ax1 = fig.axes[0]
    x, y = _xy(ax1, "measured gain g")
    index = np.arange(len(summary))
    np.testing.assert_array_equal(x, index)
    np.testing.assert_allclose(y, summary["measured_gain"], equal_nan=True)
    _assert_failed_marked(ax1, index, summary)


SHOWS = {
    "backlash": _shows_backlash,
    "hysteresis": _shows_hysteresis,
    "rate_limit": _shows_rate_limit,
    "noise": _shows_noise,
    "flight_grid": _shows_flight_grid,
    "other": _shows_other,
}


def _saved_figures(monkeypatch: pytest.MonkeyPatch) -> list[Any]:
    """The figures ``plot_sweep`` (and so ``probing plot sweep``) saves, as they are saved."""
    saved: list[Any] = []
    save_figure = sweep_plots.save_figure

    def spy(fig: Any, *args: Any, **kwargs: Any) -> list[Path]:
        saved.append(fig)
        return save_figure(fig, *args, **kwargs)

    monkeypatch.setattr(sweep_plots, "save_figure", spy)
    return saved


def test_backlash_figure_shows_the_measured_gains_over_the_closed_form(tmp_path):
    fig, summary = _figure(_backlash(tmp_path, failed={3}))
    _shows_backlash(fig, summary)
    np.testing.assert_allclose(
        _failed_x(fig.axes[0], 1), summary["nonlinearity.width_deg"][[3]] / A
    )
    plt.close(fig)


def test_hysteresis_figure_follows_the_zipped_thresholds(tmp_path):
    fig, summary = _figure(_hysteresis(tmp_path, failed=set()))
    _shows_hysteresis(fig, summary)
    np.testing.assert_allclose(_xy(fig.axes[0], "measured gain g")[1], 0.5)
    plt.close(fig)


def test_rate_limit_figure_puts_the_gains_at_r_over_the_bound(tmp_path):
    fig, summary = _figure(_rate_limit(tmp_path, failed={0}))
    _shows_rate_limit(fig, summary)
    np.testing.assert_allclose(_failed_x(fig.axes[0], 1), [0.25])
    plt.close(fig)


def test_noise_figure_plots_measured_against_naive_and_closed_form(tmp_path):
    fig, summary = _figure(_noise(tmp_path, failed={2}))
    _shows_noise(fig, summary)
    assert len(_xy(fig.axes[0], "a = 0.005 deg")[0]) == 1  # point 2 failed, point 0 has sigma 0
    plt.close(fig)


def test_flight_grid_figure_colours_measured_over_predicted(tmp_path):
    fig, summary = _figure(_flight_grid(tmp_path, failed={0, 3, 8}))
    _shows_flight_grid(fig, summary)
    plt.close(fig)


def test_other_figure_plots_gain_by_point_index(tmp_path):
    fig, summary = _figure(_other(tmp_path, failed={1}))
    _shows_other(fig, summary)
    np.testing.assert_allclose(_failed_x(fig.axes[0], 1), [1])
    plt.close(fig)


@pytest.mark.parametrize("case", sorted(KINDS))
def test_every_point_failed_still_draws_and_marks_them_all(tmp_path, case):
    make, kind, _ = KINDS[case]
    data = load_sweep_data(make(tmp_path / "sweeps", set(range(100))))
    assert classify(data) == kind
    fig = sweep_figure(data)
    n = len(data.summary)
    labels = [ln.get_label() for ax in fig.axes for ln in ax.get_lines()]
    if kind == "flight_grid":  # every cell of both heat maps says so
        for ax in fig.axes[:2]:
            assert [t.get_text() for t in ax.texts] == ["failed"] * n
    elif kind == "noise":  # nothing to plot: the figure says why
        title = " ".join(fig.get_suptitle().split())  # wrapped
        assert f"{n} failed (trim/divergence) points not shown" in title
    else:
        assert f"failed (trim/divergence): {n}" in labels
    assert not any(lab.startswith("measured gain") for lab in labels)
    plt.close(fig)


@pytest.mark.parametrize("case", sorted(KINDS))
def test_each_kind_is_classified_and_saved(tmp_path, case, monkeypatch):
    """Each kind gets its layout, and the file written shows the summary's numbers."""
    make, kind, failed = KINDS[case]
    folder = make(tmp_path / "sweeps", failed)
    assert classify(load_sweep_data(folder)) == kind
    saved = _saved_figures(monkeypatch)
    paths = plot_sweep(folder, tmp_path / "figures")
    assert paths == [tmp_path / "figures" / f"sweep_{load_sweep_data(folder).name}.png"]
    _assert_png(paths[0])
    (fig,) = saved
    summary = pd.read_parquet(folder / "summary.parquet")  # written in point order
    SHOWS[case](fig, summary)


# ------------------------------------------------------------------ the theory curve
def _scenario(nl: dict[str, Any]) -> Any:
    return parse_scenario({**BASE, "nonlinearity": nl})


def test_theory_curve_backlash_is_the_closed_form():
    scn = _scenario({"type": "backlash", "width_deg": 0.0})
    widths = [0.0, 0.003, 0.011]
    params, gain, offset = theory_curve(scn, {"nonlinearity.width_deg": widths})
    w = params["nonlinearity.width_deg"]
    assert w.size >= 200 and np.all(np.diff(w) > 0)
    assert w[0] == 0.0 and w[-1] == 0.011 and np.isin(widths, w).all()  # the points are knots
    np.testing.assert_allclose(gain, np.clip(1 - w / (2 * A), 0, None), rtol=0, atol=1e-12)
    np.testing.assert_array_equal(offset, 0.0)


def test_theory_curve_interpolates_zipped_parameters_together():
    scn = _scenario({"type": "deadband", "lower_deg": 0.0, "upper_deg": 0.0})
    d = [0.0, 0.002, 0.006]
    params, gain, _ = theory_curve(
        scn, {"nonlinearity.lower_deg": [-x for x in d], "nonlinearity.upper_deg": d}, n=50
    )
    up, lo = params["nonlinearity.upper_deg"], params["nonlinearity.lower_deg"]
    np.testing.assert_allclose(lo, -up)
    np.testing.assert_allclose(gain, np.clip(1 - up / A, 0, None), atol=1e-12)


def test_theory_curve_hysteresis_drops_to_zero_when_the_probe_cannot_switch():
    scn = _scenario(
        {
            "type": "hysteresis_relay",
            "lower_threshold_deg": 0.0,
            "upper_threshold_deg": 0.0,
            "low_deg": -A / 2,
            "high_deg": A / 2,
        }
    )
    w = [0.0, 0.006]
    params, gain, offset = theory_curve(
        scn,
        {
            "nonlinearity.lower_threshold_deg": [-x for x in w],
            "nonlinearity.upper_threshold_deg": w,
        },
    )
    up = params["nonlinearity.upper_threshold_deg"]
    np.testing.assert_allclose(gain, np.where(up < A, 0.5, 0.0))
    np.testing.assert_allclose(offset, np.where(up < A, 0.0, -A / 2))


def test_theory_curve_rejects_a_field_that_is_no_parameter():
    scn = _scenario({"type": "backlash", "width_deg": 0.0})
    with pytest.raises(ValueError, match="not a parameter of backlash"):
        theory_curve(scn, {"nonlinearity.rate_deg_s": [1.0, 2.0]})


def test_reconstructed_scenarios_apply_fixed_then_values(tmp_path):
    data = load_sweep_data(_rate_limit(tmp_path, set()))
    scn = data.scenario(2)
    assert scn.bit_duration_s == 0.04 and scn.nonlinearity == "rate_limit"
    assert scn.nl_params["rate_deg_s"] == 0.25
    assert data.varying == ["nonlinearity.rate_deg_s"]


# ------------------------------------------------------------------ command line
def test_not_a_sweep_folder_gives_exit_2_and_one_line(tmp_path, capsys):
    code = cli_main(["plot", "sweep", str(tmp_path / "nope"), "--figures", str(tmp_path / "f")])
    assert code == 2
    out, err = capsys.readouterr()
    assert out == ""
    assert err.splitlines() == [
        f"probing: error: {tmp_path / 'nope'}: not a sweep folder (no summary.parquet); "
        "run probing sweep first"
    ]
    assert not (tmp_path / "f").exists()


def test_plot_sweep_draws_into_the_sweep_folder_by_default(tmp_path, capsys):
    folder = _other(tmp_path / "sweeps", set())
    assert cli_main(["plot", "sweep", str(folder)]) == 0
    assert capsys.readouterr().out.splitlines() == [
        f"wrote {folder / 'figures' / 'sweep_order.png'}"
    ]


def test_cli_plot_sweep_prints_the_files(tmp_path, capsys, monkeypatch):
    """Both files printed and written, from one figure that shows the summary's gains."""
    monkeypatch.setattr(sweep_plots, "FORMATS", ("png", "pdf"))
    saved = _saved_figures(monkeypatch)
    folder = _other(tmp_path / "sweeps", {2})
    figures = tmp_path / "figs"
    assert cli_main(["plot", "sweep", str(folder), "--figures", str(figures)]) == 0
    out, err = capsys.readouterr()
    assert out.splitlines() == [f"wrote {figures / 'sweep_order'}.{ext}" for ext in ("png", "pdf")]
    assert err == ""
    _assert_png(figures / "sweep_order.png")
    assert (figures / "sweep_order.pdf").read_bytes().startswith(b"%PDF")
    (fig,) = saved
    summary = pd.read_parquet(folder / "summary.parquet")
    _shows_other(fig, summary)
    np.testing.assert_allclose(_xy(fig.axes[0], "measured gain g")[1], [1.0, 0.999, np.nan])
