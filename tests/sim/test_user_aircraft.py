"""An aircraft folder of the user's (``aircraft.model`` a path): the stock 737 copied under
another name flies, and matches its ground truth, exactly as the stock 737 does; a folder that
is not an aircraft, or does not load, is one line and exit code 2."""

from __future__ import annotations

import json
import shutil
from pathlib import Path

import numpy as np
import pandas as pd
import pyarrow.parquet as pq
import pytest

from probing.cli import main as cli_main
from probing.sim.aircraft import aircraft_digest, find_aircraft, stock_root

pytestmark = pytest.mark.jsbsim

ROOT = Path(__file__).resolve().parents[2]
FILES = ("probing", "timeseries", "truth", "prediction")


def copy_737(folder: Path) -> Path:
    """The stock 737 as ``folder/my737`` (``my737.xml``), its engines in ``Engines/``."""
    target = folder / "my737"
    shutil.copytree(stock_root() / "aircraft" / "737", target)
    (target / "737.xml").rename(target / "my737.xml")
    (target / "Engines").mkdir()
    for name in ("CFM56", "direct"):
        shutil.copy(stock_root() / "engine" / f"{name}.xml", target / "Engines")
    return target


def scenario_file(folder: Path, name: str, model: str, **condition: float) -> Path:
    """The baseline 737 scenario, 4 periods, named ``name``, flying ``model``."""
    text = (ROOT / "scenarios" / "baseline-737.toml").read_text()
    text = text.replace('model = "737"', f'model = "{model}"')
    text = text.replace('name = "baseline-737"', f'name = "{name}"')
    text = text.replace("periods = 8", "periods = 4")
    for key, value in condition.items():
        text = text.replace(f"{key} = ", f"{key} = {value}\n# was: ", 1)
    path = folder / f"{name}.toml"
    path.write_text(text)
    return path


@pytest.fixture
def cache(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setenv("PROBING_CACHE", str(tmp_path / "cache"))


def test_copied_737_flies_as_the_stock_one(tmp_path: Path, cache: None) -> None:
    planes = tmp_path / "planes"
    planes.mkdir()
    folder = copy_737(planes)
    scenarios = tmp_path / "scenarios"
    scenarios.mkdir()
    # relative to the scenario file, as a sweep's base is relative to the sweep file
    mine = scenario_file(scenarios, "mine", "../planes/my737")
    stock = scenario_file(scenarios, "stock", "737")
    out = tmp_path / "out"
    for path in (mine, stock):
        assert cli_main(["run", str(path), "--out", str(out), "--truth"]) == 0
    for name in FILES:
        a = pd.read_parquet(out / "mine" / f"{name}.parquet")
        b = pd.read_parquet(out / "stock" / f"{name}.parquet")
        assert a.columns.equals(b.columns)
        num = a.select_dtypes("number").columns
        assert np.array_equal(a[num].to_numpy(), b[num].to_numpy(), equal_nan=True), name
    # the estimate matches its ground truth as test_run's does (1 % relative L2 per period)
    pr = pd.read_parquet(out / "mine" / "probing.parquet")
    pred = pd.read_parquet(out / "mine" / "prediction.parquet")
    for channel in ("theta_rad", "q_rad_s", "alpha_rad"):
        for period in (2, 3):
            sel = (pr.channel == channel) & (pr.period == period)
            z, zp = pr[sel].z.to_numpy(), pred[(pred.channel == channel) & (pred.period == period)]
            zp = zp.z.to_numpy()
            assert np.linalg.norm(z - zp) / np.linalg.norm(zp) < 0.01, (channel, period)
    # provenance: the folder's absolute path and the digest of its files
    meta = pq.read_schema(out / "mine" / "probing.parquet").metadata
    spec = json.loads(meta[b"probing.aircraft"])
    assert spec["model"] == str(folder.resolve())
    assert spec["aircraft_sha256"] == aircraft_digest(str(folder.resolve()))
    assert json.loads(meta[b"probing.scenario"])["aircraft"]["model"] == str(folder.resolve())


def test_digest_follows_the_files(tmp_path: Path) -> None:
    folder = copy_737(tmp_path)
    model = str(folder)
    before = aircraft_digest(model)
    assert aircraft_digest(model) == before  # stable
    assert find_aircraft(model) == folder
    xml = folder / "my737.xml"
    xml.write_text(xml.read_text().replace("</fdm_config>", "<!-- changed -->\n</fdm_config>"))
    assert aircraft_digest(model) != before


def one_line(capsys: pytest.CaptureFixture[str], *needles: str) -> None:
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and err.startswith("probing: error: "), err
    for needle in needles:
        assert needle in err, (needle, err)


def test_a_folder_that_is_no_aircraft_is_refused(tmp_path: Path, cache: None, capsys) -> None:
    (tmp_path / "empty").mkdir()
    (tmp_path / "notes").mkdir()
    (tmp_path / "notes" / "notes.xml").write_text("<notes/>")
    (tmp_path / "broken").mkdir()
    (tmp_path / "broken" / "broken.xml").write_text('<fdm_config name="broken"></fdm_config>')
    out = tmp_path / "out"
    cases = {"./empty": "no empty.xml", "./notes": "not a JSBSim aircraft", "./broken": "load"}
    for model, needle in cases.items():
        path = scenario_file(tmp_path, model[2:], model)
        assert cli_main(["run", str(path), "--out", str(out)]) == 2
        one_line(capsys, "aircraft", needle)
    assert not out.exists()  # nothing written


def test_a_folder_jsbsim_cannot_load_says_why_and_leaves_no_copy(
    tmp_path: Path, cache: None, capsys
) -> None:
    """The stock DHC-6 copied without its propeller (Engines/Propeller.xml, which JSBSim's
    own engine folder does not have): one line with JSBSim's reason, naming the missing
    file and the user's folder (not the cache's copy), exit 2, nothing in the cache; put
    back, the next load works without clearing the cache."""
    from probing.sim.plant import Plant

    folder = tmp_path / "mydhc6"
    shutil.copytree(stock_root() / "aircraft" / "DHC6", folder)
    (folder / "DHC6.xml").rename(folder / "mydhc6.xml")
    propeller = (folder / "Engines" / "Propeller.xml").read_bytes()
    (folder / "Engines" / "Propeller.xml").unlink()
    assert not (stock_root() / "engine" / "Propeller.xml").exists()
    path = scenario_file(tmp_path, "dhc6", "./mydhc6")
    out = tmp_path / "out"
    assert cli_main(["run", str(path), "--out", str(out)]) == 2
    one_line(capsys, "could not load", str(folder), "Could not open file: Propeller")
    assert not out.exists()
    roots = tmp_path / "cache" / "jsbsim-root"
    assert [p.name for p in roots.iterdir()] == []  # no broken copy, no temporary
    (folder / "Engines" / "Propeller.xml").write_bytes(propeller)
    Plant(str(folder), 0.01)  # loads
    assert len(list(roots.iterdir())) == 1


def test_a_folder_that_does_not_trim_is_exit_2(tmp_path: Path, cache: None, capsys) -> None:
    copy_737(tmp_path)
    slow = {"altitude_ft": 45000, "speed_kcas": 90}
    path = scenario_file(tmp_path, "slow", "./my737", **slow)
    assert cli_main(["run", str(path), "--out", str(tmp_path / "out")]) == 2
    one_line(capsys, "trim failed", "my737")
    stock = scenario_file(tmp_path, "slow-stock", "737", **slow)
    assert cli_main(["run", str(stock), "--out", str(tmp_path / "out")]) == 1  # a run failed
    one_line(capsys, "trim failed")


def test_a_sweep_takes_a_folder_relative_to_the_sweep_file(tmp_path: Path) -> None:
    from probing.sweep import load_sweep

    (tmp_path / "planes").mkdir()
    folder = copy_737(tmp_path / "planes")
    sweeps = tmp_path / "sweeps"
    sweeps.mkdir()
    scenario_file(sweeps, "base", "737")
    path = sweeps / "models.toml"
    path.write_text(
        'name = "models"\nbase = "base.toml"\n'
        '[grid]\n"aircraft.model" = ["737", "../planes/my737"]\n'
    )
    models = [p.scenario.model for p in load_sweep(path).points]
    assert models == ["737", str(folder.resolve())]
