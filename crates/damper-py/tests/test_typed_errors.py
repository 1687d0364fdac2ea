"""Typed failures: an analysis that refuses a request raises the `DamperError` subclass of its
kind, with the fields a caller acts on, and with the text the command line prints for the same
request (its `error:` line); every one pickles with its fields."""

from __future__ import annotations

import pickle
from pathlib import Path
from typing import Any, Callable

import pytest

import damper
from conftest import cli


def cli_error(*args: str) -> str:
    """The command line's one error line (without `error: `) for `args`, which must fail."""
    out = cli(*args, check=False)
    assert out.returncode == 2, out
    lines = [l for l in out.stderr.splitlines() if l.startswith("error: ")]
    assert len(lines) == 1, out.stderr
    return lines[0][len("error: ") :]


def raised(kind: type, call: Callable[[], Any]) -> Any:
    """The exception of `kind` that `call` raises; it pickles to an equal one."""
    with pytest.raises(kind) as e:
        call()
    err = e.value
    assert isinstance(err, damper.DamperError)
    back = pickle.loads(pickle.dumps(err))
    assert type(back) is type(err) and str(back) == str(err)
    assert back.__dict__ == err.__dict__
    return err


def test_argument_error_names_the_keyword_and_the_option(root: Path, tmp_path: Path) -> None:
    scenario = root / "scenarios" / "damper.toml"
    sc = damper.Scenario.load(scenario)
    e = raised(damper.ArgumentError, lambda: sc.frf(1.0, 1.0, 10.0, points=1))
    assert issubclass(type(e), ValueError)
    assert (e.argument, e.option) == ("points", "--points")
    assert e.message == str(e) == "--points: at least 2"
    line = cli_error("frf", str(scenario), "--output", "1.0", "--from", "1", "--to", "10", "--points", "1", "-o", str(tmp_path / "o"))
    assert line == e.message
    e = raised(damper.ArgumentError, lambda: sc.linearize(modes=0))
    assert (e.argument, e.message) == ("modes", "--modes must be at least 1")


def test_unknown_names_list_the_valid_ones(root: Path, tmp_path: Path) -> None:
    scenario = root / "scenarios" / "damper.toml"
    sc = damper.Scenario.load(scenario)
    e = raised(damper.UnknownName, lambda: sc.frf("nosuch/x", 1.0, 10.0, points=3))
    assert issubclass(type(e), ValueError)
    assert (e.what, e.name, e.nearest) == ("mechanism", "nosuch", ["damper"])
    line = cli_error("frf", str(scenario), "--output", "nosuch/x", "--from", "1", "--to", "10", "-o", str(tmp_path / "o"))
    assert line == e.message == str(e)
    e = raised(damper.UnknownName, lambda: sc.frf("damper/nosuch", 1.0, 10.0, points=3))
    assert e.what == "coordinate" and e.name == "nosuch" and len(e.nearest) >= 1
    vary = {"generator.load_resistance": (1.0, 10.0)}
    e = raised(damper.UnknownName, lambda: sc.optimize(vary, maximize="powr"))
    assert (e.what, e.name) == ("figure", "powr")
    assert "power" in e.nearest
    line = cli_error("optimize", str(scenario), "--vary", "generator.load_resistance=1:10", "--maximize", "powr")
    assert line == e.message
    e = raised(damper.UnknownName, lambda: sc.optimize(vary, maximize="power", constraints=["linear.reach>=2*random.rmss:1.0"]))
    assert e.what == "figure" and e.name.startswith("random.rmss")


def test_what_a_scenario_cannot_give_names_the_file(root: Path) -> None:
    scenario = root / "scenarios" / "damper.toml"
    sc = damper.Scenario.load(scenario)
    e = raised(damper.NotAvailable, lambda: sc.random())
    assert e.file == str(scenario)
    assert e.message == cli_error("random", str(scenario))
    mech = damper.Scenario.load(root / "scenarios" / "four_bar.toml")
    e = raised(damper.NotAvailable, lambda: mech.linearize())
    assert e.file is not None and e.file.endswith("four_bar.toml")
    assert "no beam to linearise" in e.message


def test_an_infeasible_optimisation_says_how_far_it_looked(root: Path) -> None:
    scenario = root / "scenarios" / "damper.toml"
    sc = damper.Scenario.load(scenario)
    # A damping ratio above 1 is out of reach of every load resistance.
    e = raised(
        damper.OptimizationError,
        lambda: sc.optimize({"generator.load_resistance": (1.0, 10.0)}, maximize="power", constraints=["linear.zeta1>=1.5"], grid=3),
    )
    assert e.file == str(scenario)
    assert isinstance(e.evaluations, int) and e.evaluations > 0
    assert e.least_infeasible is not None and "linear.zeta1" in e.least_infeasible
    assert str(e).startswith(f"{scenario}: no point satisfies the constraints ({e.evaluations} evaluated)")


def test_work_above_the_limits_is_a_work_limit_error(root: Path) -> None:
    sc = damper.Scenario.load(root / "scenarios" / "damper.toml")
    axes = {"generator.load_resistance": "1:10:2000", "mechanism.half_angle_deg": "10:40:2000"}
    e = raised(damper.WorkLimitError, lambda: sc.sweep(axes))
    assert "allow-long" in e.message or "allow_long" in e.message


def test_grid_specifications_are_argument_errors(root: Path) -> None:
    sc = damper.Scenario.load(root / "scenarios" / "damper.toml")
    e = raised(damper.ArgumentError, lambda: sc.sweep({"generator.load_resistance": "1:10:0"}))
    assert (e.argument, e.option) == ("axes", "--set")
    assert e.message == "--set generator.load_resistance=1:10:0: `1:10:0`: a:b:n needs n >= 2 points"
    e = raised(damper.ArgumentError, lambda: sc.optimize({"generator.load_resistance": (1.0, 10.0)}, maximize="power", constraints=["linear.zeta1=>0.1"]))
    assert (e.argument, e.option) == ("constraints", "--constraint")


def test_every_typed_failure_is_exported_and_known_to_the_fuzzer() -> None:
    from fuzz_api import DOCUMENTED

    typed = [n for n in damper.__all__ if isinstance(getattr(damper, n), type) and issubclass(getattr(damper, n), damper.DamperError)]
    assert len(typed) >= 10, typed
    for name in typed:
        cls = getattr(damper, name)
        assert cls.__module__ == "damper" and cls.__doc__, name
        assert name in DOCUMENTED, f"fuzz_api.DOCUMENTED lacks {name}"
    assert issubclass(damper.ArgumentError, ValueError) and issubclass(damper.UnknownName, ValueError)
    assert not issubclass(damper.NotAvailable, ValueError)
