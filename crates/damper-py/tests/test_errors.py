"""Errors: a broken scenario and a broken model raise `ScenarioError` / `ModelError` with the
file, line, column and entity the command line prints; a toggle stop raises
`SingularPosition` with the time and distance of the command line's message."""

from __future__ import annotations

import re
from pathlib import Path

import pytest

import damper
from conftest import cli


def first_problem(stderr: str) -> tuple:
    """`file:line:column: entity: message` of the command line's first error line."""
    line = next(l for l in stderr.splitlines() if l.strip())
    m = re.match(r"^(?:error: )?(.+?):(\d+):(\d+): (.*)$", line)
    assert m, line
    return m.group(1), int(m.group(2)), int(m.group(3)), m.group(4)


def test_broken_scenario_names_file_line_and_column(tmp_path: Path, root: Path) -> None:
    text = (root / "scenarios" / "damper.toml").read_text()
    assert "dt = 1e-4" in text
    text = text.replace("dt = 1e-4", "dt = -1e-4")
    text = text.replace('model = "../models/double_bar.toml"', f'model = "{root}/models/double_bar.toml"')
    bad = tmp_path / "bad.toml"
    bad.write_text(text)
    err = cli("simulate", str(bad), "-o", str(tmp_path / "o"), check=False)
    assert err.returncode != 0
    file, line, column, rest = first_problem(err.stderr)
    with pytest.raises(damper.ScenarioError) as e:
        damper.Scenario.load(bad)
    assert isinstance(e.value, ValueError)
    assert (e.value.file, e.value.line, e.value.column) == (file, line, column)
    assert text.splitlines()[line - 1].startswith("dt = -1e-4")
    assert e.value.message in rest
    assert "dt" in str(e.value)


def test_bad_override_names_the_option(root: Path) -> None:
    with pytest.raises(damper.ScenarioError, match="set") as e:
        damper.Scenario.load(root / "scenarios" / "damper.toml", set={"integrator.dt": "fast"})
    assert e.value.message is not None


def test_from_str_errors_name_the_string(root: Path) -> None:
    with pytest.raises(damper.ScenarioError) as e:
        damper.Scenario.from_str('kind = "mechanizm"\n', name="inline.toml")
    assert e.value.file == "inline.toml"
    assert (e.value.line, e.value.column) == (1, 8)


def test_missing_scenario_file(tmp_path: Path) -> None:
    with pytest.raises(damper.ScenarioError, match="cannot read") as e:
        damper.Scenario.load(tmp_path / "none.toml")
    assert e.value.file == str(tmp_path / "none.toml")


def test_broken_model_names_file_line_and_entity(tmp_path: Path, root: Path) -> None:
    text = (root / "models" / "double_bar.toml").read_text()
    assert 'parent = "crank"' in text
    bad = tmp_path / "bad_model.toml"
    bad.write_text(text.replace('parent = "crank"', 'parent = "crnk"', 1))
    err = cli("eval", str(bad), check=False)
    assert err.returncode != 0
    with pytest.raises(damper.ModelError) as e:
        damper.Model.load(bad)
    assert isinstance(e.value, ValueError)
    assert e.value.file == str(bad)
    line = err.stderr.strip().splitlines()[0].removeprefix("error: ")
    assert line.startswith(f"{bad}:{e.value.line}:")
    assert e.value.entity is not None and e.value.entity in line
    assert "crnk" in e.value.message
    assert text.replace('parent = "crank"', 'parent = "crnk"', 1).splitlines()[e.value.line - 1].strip().startswith("parent")


def test_toggle_stop_raises_singular_position(tmp_path: Path, monkeypatch: pytest.MonkeyPatch, root: Path) -> None:
    monkeypatch.chdir(root)
    sets = {"initial.displacement": -0.0035, "generator.connected": False, "integrator.t_end": 1.0}
    args = ["simulate", "scenarios/damper.toml", "-o", str(tmp_path / "o"), "--quiet"]
    for k, v in sets.items():
        args += ["--set", f"{k}={str(v).lower()}"]
    err = cli(*args, check=False)
    assert err.returncode != 0 and "singular position" in err.stderr
    m = re.search(r"t = ([0-9.]+) s, .* beam point displacement ([-0-9.e]+) m", err.stderr)
    assert m
    with pytest.raises(damper.SingularPosition) as e:
        damper.Scenario.load("scenarios/damper.toml", set=sets).simulate()
    assert isinstance(e.value, damper.DamperError)
    assert f"{e.value.time:.6f}" == m.group(1)
    assert float(f"{e.value.distance:.6e}") == float(m.group(2))
    assert e.value.mechanism == "damper"
    assert e.value.reach is not None and 0 <= e.value.reach < 1e-6
    assert str(e.value) in err.stderr
