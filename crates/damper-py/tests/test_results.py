"""The typed results (`Run`, `FrfResult`, `SweepResult`, `RandomResult`, `Optimum`): columns
by name with their units as metadata, the CSV headers still resolving, the same numbers as the
command line's files cell for cell (the optimiser's history included), pickling to equal
objects, the text and HTML summaries, and the matplotlib plots."""

from __future__ import annotations

import json
import pickle
from pathlib import Path
from typing import Any

import numpy as np
import pytest

import damper
from conftest import assert_cells_equal, cli, read_csv


@pytest.fixture()
def sc(monkeypatch: pytest.MonkeyPatch, root: Path) -> damper.Scenario:
    monkeypatch.chdir(root)
    return damper.Scenario.load("scenarios/damper.toml", set={"integrator.t_end": 0.2})


def assert_table_equals_csv(table: damper.Table, cells: Any, what: str) -> None:
    """Every column of the table is the CSV's column of the same header, cell for cell."""
    assert table.headers == list(cells), what
    for name, values in table.items():
        column = cells[table.header(name)]
        if isinstance(values, np.ndarray) and values.dtype == np.float64:
            assert_cells_equal(column, values, f"{what}: {name}")
        elif isinstance(values, np.ndarray):  # counts
            assert [str(v) for v in values.tolist()] == column, f"{what}: {name}"
        else:  # texts (None: an empty cell) and a sweep's values (numbers read back exactly)
            for v, c in zip(values, column):
                if isinstance(v, float):
                    assert float(c) == v, f"{what}: {name}: CSV {c}, Python {v!r}"
                else:
                    assert ("" if v is None else str(v)) == c, f"{what}: {name}: CSV {c}, Python {v!r}"
            assert len(values) == len(column), what


def test_columns_by_name_with_units_as_metadata(sc: damper.Scenario) -> None:
    sweep = sc.sweep({"mechanism.half_angle_deg": [30, 40]})
    assert isinstance(sweep, damper.SweepResult)
    assert sweep.units["linear.zeta1"] == "-" and sweep.units["linear.f1"] == "Hz"
    assert sweep["linear.zeta1"] is sweep["linear.zeta1 [-]"]
    assert "linear.zeta1" in sweep and "linear.zeta1 [-]" in sweep and "zeta1" not in sweep
    assert sweep.axes == ["mechanism.half_angle_deg"] and "linear.zeta1" in sweep.figures
    assert sweep.errors == [None, None] and len(sweep) == 2
    assert sweep["index"].dtype == np.int64 and sweep["mechanism.half_angle_deg"] == [30, 40]
    with pytest.raises(KeyError, match="no column 'zeta1'"):
        sweep["zeta1"]
    run = sc.simulate(compare=[])
    assert run.columns[0] == "t" and run.units["t"] == "s" and run.headers[0] == "t [s]"
    frf = sc.frf(1.0, 2.0, 12.0, points=5)
    assert isinstance(frf, damper.FrfResult) and frf.nonlinear is None and frf.warnings == []
    assert frf.units["|H| with generator"] == "m/N" and frf.units["f"] == "Hz"


def test_to_pandas_and_to_dict(sc: damper.Scenario) -> None:
    pytest.importorskip("pandas")
    sweep = sc.sweep({"mechanism.half_angle_deg": [30, 40]})
    df = sweep.to_pandas()
    assert list(df.columns) == sweep.columns
    np.testing.assert_array_equal(df["linear.zeta1"].to_numpy(), sweep["linear.zeta1"])
    assert list(sweep.to_pandas(headers=True).columns) == sweep.headers
    assert list(sweep.to_dict()) == sweep.columns
    rnd = damper.Scenario.load("scenarios/random_damper.toml").random(method="dense")
    rdf = rnd.to_pandas()
    assert list(rdf["output"]) == rnd.outputs and list(rdf["rms"]) == list(rnd.rms)
    opt = sc.optimize({"mechanism.half_angle_deg": (3, 25)}, maximize="zeta1", grid=3)
    assert len(opt.to_pandas()) == len(opt.history)


def test_summaries_as_text_and_html(sc: damper.Scenario) -> None:
    sweep = sc.sweep({"mechanism.half_angle_deg": [30, 40]})
    text = repr(sweep)
    assert text.startswith("SweepResult: 2 points over mechanism.half_angle_deg")
    line = next(l for l in text.splitlines() if l.strip().startswith("linear.zeta1 "))
    lo, hi = float(np.nanmin(sweep["linear.zeta1"])), float(np.nanmax(sweep["linear.zeta1"]))
    assert line.split()[1:] == ["-", f"{lo:.4g}", "..", f"{hi:.4g}"]
    assert str(sweep) == text
    page = sweep._repr_html_()
    assert page.startswith("<table>") and "<td style='text-align:left'>linear.zeta1</td>" in page
    rnd = damper.Scenario.load("scenarios/random_damper.toml").random(method="dense")
    assert repr(rnd).startswith(f"RandomResult ({rnd.method}): RMS of") and "<table>" in rnd._repr_html_()
    opt = sc.optimize({"mechanism.half_angle_deg": (3, 25)}, maximize="zeta1", grid=3)
    assert repr(opt).startswith(f"Optimum after {len(opt.history)} evaluations")
    assert "mechanism.half_angle_deg" in opt._repr_html_()
    # HTML escapes what it shows (|H| <, >, & in names would otherwise break the page).
    frf = sc.frf(1.0, 2.0, 12.0, points=5)
    assert "<td style='text-align:left'>|H| with generator</td>" in frf._repr_html_()


def test_results_pickle_to_equal_objects(sc: damper.Scenario) -> None:
    rnd_sc = damper.Scenario.load("scenarios/random_damper.toml")
    results = [
        sc,
        sc.with_set({"generator.load_resistance": np.array([4.0])[0]}),
        sc.simulate(compare=["bare_beam"]),
        sc.linearize(modes=2, matrices=True),
        sc.frf(1.0, 2.0, 12.0, points=5),
        sc.sweep({"mechanism.half_angle_deg": [30, 40]}),
        sc.sweep_shard({"mechanism.half_angle_deg": [30, 40]}, 1, 2),
        rnd_sc.random(method="dense"),
        sc.optimize({"mechanism.half_angle_deg": (3, 25)}, maximize="zeta1", grid=3),
    ]
    for r in results:
        back = pickle.loads(pickle.dumps(r))
        assert type(back) is type(r) and back == r, type(r).__name__
    # Equality can fail: a changed cell, a changed override.
    sweep = results[5]
    other = pickle.loads(pickle.dumps(sweep))
    other["linear.zeta1"][0] += 1e-16
    assert other != sweep
    assert sc != sc.with_set({"integrator.t_end": 0.3})


def test_frf_equals_the_cli_by_name_and_unit(sc: damper.Scenario, tmp_path: Path) -> None:
    cli("frf", "scenarios/damper.toml", "--output", "1.0", "--from", "2", "--to", "12", "--points", "30",
        "--set", "integrator.t_end=0.2", "-o", str(tmp_path))
    frf = sc.frf(1.0, 2.0, 12.0, points=30)
    assert_table_equals_csv(frf, read_csv(tmp_path / "frf.csv"), "frf.csv")


def test_sweep_equals_the_cli_by_name_and_unit(sc: damper.Scenario, tmp_path: Path) -> None:
    cli("sweep", "scenarios/damper.toml", "--set", "integrator.t_end=0.2", "--set", "mechanism.half_angle_deg=30,45",
        "--set", "generator.load_resistance=1:9:3", "-o", str(tmp_path), "--quiet")
    sweep = damper.Scenario.load("scenarios/damper.toml").sweep(
        {"integrator.t_end": [0.2], "mechanism.half_angle_deg": [30, 45], "generator.load_resistance": "1:9:3"}
    )
    assert_table_equals_csv(sweep, read_csv(tmp_path / "sweep.csv"), "sweep.csv")


def test_random_equals_the_cli_output_by_output(monkeypatch: pytest.MonkeyPatch, root: Path) -> None:
    """The RMS of every output and the generators' figures, by name, equal `damper random
    --json` (which prints full precision: compared exactly)."""
    monkeypatch.chdir(root)
    expected = json.loads(cli("random", "scenarios/random_damper.toml", "--json").stdout)
    rnd = damper.Scenario.load("scenarios/random_damper.toml").random()
    assert rnd.report == expected and rnd.method == expected["method"]
    assert rnd.outputs == [o["name"] for o in expected["outputs"]]
    for o in expected["outputs"]:
        assert rnd[o["name"]] == o["rms"] and rnd.units[o["name"]] == o["unit"]
    for g in expected["generators"]:
        assert rnd.generators[g["name"]]["mean_power_load"] == g["mean_power_load"]


def test_optimum_and_its_history_equal_the_cli(sc: damper.Scenario, tmp_path: Path) -> None:
    """`optimize.json` and `optimize_history.csv` of `damper optimize -o DIR`: the report
    and the history cell for cell (a constraint between figures adds its right-hand column)."""
    args = ["--vary", "mechanism.half_angle_deg=3:25", "--maximize", "zeta1",
            "--constraint", "reach>=0.002", "--constraint", "linear.f1>=0.01*linear.amplification"]
    cli("optimize", "scenarios/damper.toml", *args, "--set", "integrator.t_end=0.2", "-o", str(tmp_path), "--json")
    opt = sc.optimize({"mechanism.half_angle_deg": (3, 25)}, maximize="zeta1",
                      constraints=["reach>=0.002", "linear.f1>=0.01*linear.amplification"])
    expected = json.loads((tmp_path / "optimize.json").read_text())
    assert opt.report == expected and opt["optimum"] == expected["optimum"]
    assert opt.x == dict(expected["optimum"]) and opt.objective == tuple(expected["objective"])
    history = read_csv(tmp_path / "optimize_history.csv")
    assert opt.history.columns[-2] == "linear.amplification"
    assert_table_equals_csv(opt.history, history, "optimize_history.csv")


def test_plots_return_matplotlib_axes(sc: damper.Scenario, tmp_path: Path) -> None:
    matplotlib = pytest.importorskip("matplotlib")
    matplotlib.use("Agg")
    run = sc.simulate(compare=[])
    ax = run.plot(columns=["pin.w"])
    assert ax.get_xlabel() == "t [s]" and ax.get_ylabel() == "[m]"
    np.testing.assert_array_equal(ax.lines[0].get_ydata(), run["pin.w"])
    frf = sc.frf(1.0, 2.0, 12.0, points=5)
    ax = frf.plot()
    assert ax.get_xscale() == "log" and len(ax.lines) == 2
    np.testing.assert_array_equal(ax.lines[0].get_ydata(), frf["|H| with generator"])
    two = sc.sweep({"mechanism.half_angle_deg": [20, 30, 40], "generator.load_resistance": [2, 4, 8, 16]})
    ax = two.plot_map("linear.zeta1")
    assert ax.get_xlabel() == "mechanism.half_angle_deg" and ax.get_ylabel() == "generator.load_resistance"
    assert ax.figure.axes[-1].get_ylabel() == "linear.zeta1 [-]"  # the colour bar
    ax.figure.savefig(tmp_path / "map.png")
    assert (tmp_path / "map.png").read_bytes()[:4] == b"\x89PNG"
    one = sc.sweep({"mechanism.half_angle_deg": [40, 20, 30]})
    ax = one.plot_map("linear.f1")
    np.testing.assert_array_equal(ax.lines[0].get_xdata(), [20.0, 30.0, 40.0])
    three = sc.sweep({"mechanism.half_angle_deg": [20, 30], "generator.load_resistance": [2, 4], "integrator.t_end": [0.1, 0.2]})
    with pytest.raises(ValueError, match="one or two varying axes"):
        three.plot_map()
