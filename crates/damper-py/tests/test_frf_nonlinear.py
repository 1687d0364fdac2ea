"""`Scenario.frf(nonlinear=M)` against `damper frf --nonlinear M`: the columns of
`frf_nonlinear.csv` cell for cell (settled runs, runs stopped at `max_periods` with empty
load-power cells, runs stopped at the toggle with an error), the linear columns unchanged,
and the command's one-line refusals of bad values and of too long runs."""

from __future__ import annotations

from pathlib import Path
from typing import Any, Dict, List

import numpy as np
import pytest

import damper
from conftest import assert_cells_equal, cli, read_csv

SCENARIO = "scenarios/forced_damper.toml"

# forced_damper (5-7 Hz, 40 periods at most): 5 and 6 Hz settle (34 and 36 periods), 7 Hz does
# not (its measured load power is an empty cell); a force of 2 N drives every run past the
# mechanism's reach (an error, the measured cells empty).
CASES = {
    "settled and not": (None, 40),
    "stopped at the reach": (2.0, 40),
}


def compare(cells: Dict[str, List[str]], table: Any, what: str) -> None:
    assert table.headers == list(cells), what
    for name, values in table.items():
        name = table.header(name)
        if name == "settled":
            assert values.dtype == np.bool_
            assert [str(v).lower() for v in values] == cells[name], name
        elif name == "periods":
            assert values.dtype == np.int64
            assert [int(c) for c in cells[name]] == list(values), name
        elif name == "error":
            assert [v or "" for v in values] == cells[name], name
        else:
            assert values.dtype == np.float64
            assert_cells_equal(cells[name], values, f"{what} {name}")


@pytest.mark.parametrize("case", list(CASES))
def test_nonlinear_frf_equals_the_cli(case: str, tmp_path: Path, monkeypatch: pytest.MonkeyPatch, root: Path) -> None:
    force, max_periods = CASES[case]
    monkeypatch.chdir(root)
    extra = [] if force is None else ["--force", str(force)]
    cli("frf", SCENARIO, "--output", "1.0", "--from", "5", "--to", "7", "--points", "20", "--nonlinear", "3",
        "--max-periods", str(max_periods), "--quiet", "-o", str(tmp_path), *extra)
    sc = damper.Scenario.load(SCENARIO)
    cols = sc.frf(1.0, 5.0, 7.0, points=20, force=force, nonlinear=3, max_periods=max_periods)
    nl = cols.nonlinear
    assert nl is not None
    compare(read_csv(tmp_path / "frf_nonlinear.csv"), nl, case)
    # The linear columns: the CLI's, and those of the call without `nonlinear`.
    linear = read_csv(tmp_path / "frf.csv")
    alone = sc.frf(1.0, 5.0, 7.0, points=20, force=force)
    assert cols.headers == list(linear) == alone.headers and alone.nonlinear is None
    for name, values in cols.items():
        assert_cells_equal(linear[cols.header(name)], values, name)
        np.testing.assert_array_equal(values, alone[name])
    settled = list(nl["settled"])
    if force is None:
        assert settled == [True, True, False] and nl["error"] == [None, None, None]
        assert np.isnan(nl["generator.load_power"][2]) and nl.units["generator.load_power"] == "W"
    else:
        assert settled == [False] * 3 and all("cannot reach" in e for e in nl["error"])
        assert np.isnan(nl["amplitude [m]"]).all()


BAD = [
    ({"nonlinear": 0}, ["--nonlinear", "0"]),
    ({"nonlinear": 3, "tolerance": 2.0}, ["--nonlinear", "3", "--tolerance", "2"]),
    ({"nonlinear": 3, "steps_per_period": 4}, ["--nonlinear", "3", "--steps-per-period", "4"]),
]


@pytest.mark.parametrize("kwargs,args", BAD, ids=["nonlinear=0", "tolerance=2", "steps_per_period=4"])
def test_bad_nonlinear_options_raise_the_cli_message(kwargs: Dict[str, Any], args: List[str], monkeypatch: pytest.MonkeyPatch, root: Path) -> None:
    monkeypatch.chdir(root)
    err = cli("frf", SCENARIO, "--output", "1.0", "--from", "5", "--to", "7", *args, check=False)
    assert err.returncode != 0
    [line] = err.stderr.strip().splitlines()
    with pytest.raises(ValueError) as e:
        damper.Scenario.load(SCENARIO).frf(1.0, 5.0, 7.0, **kwargs)
    assert f"error: {e.value}" == line


def test_too_long_nonlinear_runs_are_refused_unless_allow_long(monkeypatch: pytest.MonkeyPatch, root: Path) -> None:
    """30 frequencies of at most 10,000 periods: 6e7 time steps at most, above the limit of
    2e7; they settle within 50 periods each (well under a second)."""
    monkeypatch.chdir(root)
    args = ["--nonlinear", "30", "--max-periods", "10000"]
    err = cli("frf", SCENARIO, "--output", "1.0", "--from", "5", "--to", "7", *args, check=False)
    assert err.returncode != 0
    [line] = err.stderr.strip().splitlines()
    assert "--allow-long" in line
    sc = damper.Scenario.load(SCENARIO)
    with pytest.raises(damper.DamperError) as e:
        sc.frf(1.0, 5.0, 7.0, nonlinear=30, max_periods=10000)
    assert f"error: {e.value}" == line
    cols = sc.frf(1.0, 5.0, 7.0, nonlinear=30, max_periods=10000, allow_long=True)
    assert cols.nonlinear is not None and list(cols.nonlinear["settled"]) == [True] * 30
