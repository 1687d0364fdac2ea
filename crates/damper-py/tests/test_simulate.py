"""`Scenario.simulate` against `damper simulate` on every bundled scenario: the same summary
(wall-clock fields aside) and the same time histories, every number equal to the CSV's
printed (shortest round-trip) value."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

import damper
from conftest import SCENARIOS, assert_cells_equal, cli, load_json, read_csv, without_wall


@pytest.mark.parametrize("scenario", SCENARIOS, ids=lambda p: p.stem)
def test_simulate_equals_the_cli(scenario: Path, tmp_path: Path, monkeypatch: pytest.MonkeyPatch, root: Path) -> None:
    monkeypatch.chdir(root)
    rel = str(scenario.relative_to(root))
    cli("simulate", rel, "-o", str(tmp_path), "--quiet")
    sc = damper.Scenario.load(rel)
    run = sc.simulate()
    if sc.kind == "mechanism":
        csv_path = tmp_path / f"{scenario.stem}.csv"
        summary = load_json(tmp_path / f"{scenario.stem}_summary.json")
    else:
        csv_path = tmp_path / "time_history.csv"
        summary = load_json(tmp_path / "summary.json")
    assert without_wall(run.summary) == without_wall(summary)
    cells = read_csv(csv_path)
    assert run.headers == list(cells)
    for name in run.columns:
        assert isinstance(run[name], np.ndarray) and run[name].dtype == np.float64
        assert_cells_equal(cells[run.header(name)], run[name], f"{scenario.stem}: {name}")
    assert len(run) == summary.get("output_rows", len(run))
    # Under random excitation, the response spectra: the table of random_psd.csv.
    psd_path = tmp_path / "random_psd.csv"
    assert (run.psd is not None) == psd_path.exists()
    if run.psd is not None:
        cells = read_csv(psd_path)
        assert run.psd.headers == list(cells)
        assert run.psd.units["w(x=1) estimate"] == "m^2/Hz"
        for name in run.psd.columns:
            assert_cells_equal(cells[run.psd.header(name)], run.psd[name], f"{scenario.stem} psd: {name}")
        assert summary["random"]["psd"]["file"] == "random_psd.csv"
    # The comparison runs: their files and their summary blocks.
    expected = sorted(p.name[len("time_history_"):-4] for p in tmp_path.glob("time_history_*.csv"))
    assert sorted(run.comparisons) == expected
    for key, other in run.comparisons.items():
        assert without_wall(other.summary) == without_wall(summary["comparisons"][key])
        cells = read_csv(tmp_path / f"time_history_{key}.csv")
        assert other.headers == list(cells)
        for name in other.columns:
            assert_cells_equal(cells[other.header(name)], other[name], f"{scenario.stem} {key}: {name}")


def test_overrides_and_with_set_equal_the_cli_set(tmp_path: Path, monkeypatch: pytest.MonkeyPatch, root: Path) -> None:
    monkeypatch.chdir(root)
    cli(
        "simulate", "scenarios/damper.toml", "-o", str(tmp_path), "--quiet",
        "--set", "integrator.t_end=0.5", "--set", "mechanism.half_angle_deg=40",
    )
    summary = load_json(tmp_path / "summary.json")
    base = damper.Scenario.load("scenarios/damper.toml", set={"integrator.t_end": 0.5})
    changed = base.with_set({"mechanism.half_angle_deg": 40})
    run = changed.simulate()
    assert without_wall(run.summary) == without_wall(summary)
    assert run.summary["overrides"] == [
        {"path": "integrator.t_end", "value": 0.5},
        {"path": "mechanism.half_angle_deg", "value": 40},
    ]
    # The original is unchanged by with_set.
    assert base.sets == [("integrator.t_end", 0.5)]
    cells = read_csv(tmp_path / "time_history.csv")
    assert_cells_equal(cells["t [s]"], run["t [s]"], "t")


def test_compare_replaces_the_scenarios_comparisons(monkeypatch: pytest.MonkeyPatch, root: Path) -> None:
    monkeypatch.chdir(root)
    sc = damper.Scenario.load("scenarios/damper.toml", set={"integrator.t_end": 0.2})
    assert sorted(sc.simulate().comparisons) == ["bare_beam", "generator_disconnected"]
    only = sc.simulate(compare=["bare_beam"])
    assert list(only.comparisons) == ["bare_beam"]
    assert list(only.summary["comparisons"]) == ["bare_beam"]
    assert sc.simulate(compare=[]).comparisons == {}


def test_run_to_dict_and_to_pandas(monkeypatch: pytest.MonkeyPatch, root: Path) -> None:
    monkeypatch.chdir(root)
    run = damper.Scenario.load("scenarios/damper.toml", set={"integrator.t_end": 0.1}).simulate()
    d = run.to_dict()
    assert list(d) == run.columns
    # The arrays themselves, no copy.
    assert all(d[k] is run[k] for k in run.columns)
    # The columns are the library's buffers, moved into numpy (their base is the Rust
    # container the `numpy` crate keeps them in), not copies made by numpy.
    for name in run.columns:
        assert not run[name].flags["OWNDATA"]
        assert type(run[name].base).__name__ == "PySliceContainer"
    pd = pytest.importorskip("pandas")
    df = run.to_pandas()
    assert isinstance(df, pd.DataFrame)
    assert list(df.columns) == run.columns
    np.testing.assert_array_equal(df["t"].to_numpy(), run["t [s]"])
    assert list(run.to_pandas(headers=True).columns) == run.headers
    with pytest.raises(KeyError, match="no column"):
        run["nope"]


def test_from_str_resolves_relative_paths_against_base_dir(root: Path) -> None:
    text = (root / "scenarios" / "damper.toml").read_text()
    sc = damper.Scenario.from_str(text, base_dir=root / "scenarios")
    assert sc.kind == "hybrid"
    a = sc.with_set({"integrator.t_end": 0.05}).simulate()
    b = damper.Scenario.load(root / "scenarios" / "damper.toml", set={"integrator.t_end": 0.05}).simulate()
    for name in a.columns:
        np.testing.assert_array_equal(a[name], b[name])
    with pytest.raises(ValueError, match="toml"):
        damper.Scenario.from_str(text, kind="json")
