"""`Scenario.linearize`, `frf`, `sweep` and `optimize` against the command line, and the
reduced matrices against the modes (an independent eigen-solve of the quadratic pencil)."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

import damper
from conftest import SCENARIOS, assert_cells_equal, cli, load_json, read_csv

# The linearised analyses need a beam host: mechanisms alone have none, and an imported
# `[structure]` is not linearised yet (issue #30; its time domain is in test_simulate).
BEAM_SCENARIOS = [
    p for p in SCENARIOS if 'kind = "mechanism"' not in p.read_text() and "[structure]" not in p.read_text()
]
LINEAR_SWEEP_SCENARIOS = [p for p in SCENARIOS if "[structure]" not in p.read_text()]


@pytest.mark.parametrize("scenario", BEAM_SCENARIOS, ids=lambda p: p.stem)
def test_linearize_equals_the_cli(scenario: Path, monkeypatch: pytest.MonkeyPatch, root: Path) -> None:
    monkeypatch.chdir(root)
    rel = str(scenario.relative_to(root))
    expected = json.loads(cli("linearize", rel, "--json", "--modes", "4").stdout)
    lin = damper.Scenario.load(rel).linearize(modes=4)
    assert lin.report == expected
    assert lin.equilibrium == expected["equilibrium"]
    assert lin.amplification == expected["amplification"]
    for modes, reports in [
        (lin.modes, expected["modes"]),
        (lin.generator_disconnected, expected.get("generator_disconnected")),
        (lin.bare_beam, expected.get("bare_beam")),
    ]:
        if reports is None:
            assert modes is None
            continue
        assert modes is not None and len(modes) == len(reports)
        for m, r in zip(modes, reports):
            assert m.natural_frequency_hz == r["natural_frequency_hz"]
            assert m.damped_frequency_hz == r["damped_frequency_hz"]
            assert m.damping_ratio == r["damping_ratio"]
            assert m.decay_rate == r["decay_rate"]
            np.testing.assert_array_equal(m.beam_shape, np.array(r["beam_shape"]).reshape(-1, 3))
            coords = [(s["mechanism"], c, z) for s in r["mechanism_shape"] for c, z in s["coordinates"]]
            assert m.mechanism_coordinates == [f"{a}/{c}" for a, c, _ in coords]
            np.testing.assert_array_equal(m.mechanism_shape, np.array([z for _, _, z in coords]).reshape(-1, 2))


def test_reduced_matrices_give_the_modes(monkeypatch: pytest.MonkeyPatch, root: Path) -> None:
    """The eigenvalues of the pencil lambda^2 M_R + lambda C_R + K_R (numpy's dense solve of
    the companion form) are the modes' eigenvalues."""
    monkeypatch.chdir(root)
    # The damper's generator has no inductance: the pencil is the whole linear system.
    lin = damper.Scenario.load("scenarios/damper.toml").linearize(modes=3, method="dense", matrices=True)
    assert lin.M_R is not None and lin.C_R is not None and lin.K_R is not None
    m, c, k = lin.M_R, lin.C_R, lin.K_R
    n = m.shape[0]
    # nalgebra's column-major buffer, viewed in Fortran order (no copy).
    for a in (m, c, k):
        assert a.flags["F_CONTIGUOUS"] and type(a.base.base).__name__ == "PySliceContainer"
    assert m.shape == c.shape == k.shape == (n, n)
    np.testing.assert_allclose(m, m.T, rtol=0, atol=1e-12 * np.abs(m).max())
    np.testing.assert_allclose(k, k.T, rtol=0, atol=1e-9 * np.abs(k).max())
    a = np.block([[np.zeros((n, n)), np.eye(n)], [-np.linalg.solve(m, k), -np.linalg.solve(m, c)]])
    lam = np.linalg.eigvals(a)
    for mode in lin.modes:
        nearest = lam[np.argmin(np.abs(lam - mode.eigenvalue))]
        assert abs(nearest - mode.eigenvalue) <= 1e-7 * abs(mode.eigenvalue), (mode, nearest)


FRF_CASES = [(str(p.relative_to(p.parents[1])), "0.5") for p in BEAM_SCENARIOS] + [
    ("scenarios/damper.toml", "1.0"),
    ("scenarios/pendulum_absorber.toml", "absorber/theta"),
]


@pytest.mark.parametrize("scenario,output", FRF_CASES)
def test_frf_equals_the_cli(scenario: str, output: str, tmp_path: Path, monkeypatch: pytest.MonkeyPatch, root: Path) -> None:
    monkeypatch.chdir(root)
    out = tmp_path / Path(scenario).stem
    cli("frf", scenario, "--output", output, "--from", "1", "--to", "20", "--points", "40", "--log", "-o", str(out))
    cols = damper.Scenario.load(scenario).frf(output, 1.0, 20.0, points=40, log=True)
    cells = read_csv(out / "frf.csv")
    assert cols.headers == list(cells)
    for name, values in cols.items():
        assert_cells_equal(cells[cols.header(name)], values, f"{scenario} {name}")


@pytest.mark.parametrize("scenario", LINEAR_SWEEP_SCENARIOS, ids=lambda p: p.stem)
def test_sweep_of_every_scenario_equals_the_cli(scenario: Path, tmp_path: Path, monkeypatch: pytest.MonkeyPatch, root: Path) -> None:
    """The same linear sweep on every bundled scenario (a mechanism scenario's points fail:
    their errors are compared)."""
    monkeypatch.chdir(root)
    rel = str(scenario.relative_to(root))
    cli("sweep", rel, "--set", "integrator.t_end=1,2", "-o", str(tmp_path), "--quiet")
    res = damper.Scenario.load(rel).sweep({"integrator.t_end": [1, 2]})
    cells = read_csv(tmp_path / "sweep.csv")
    assert res.headers == list(cells)
    for name, values in res.items():
        if name == "error":
            assert [v or "" for v in values] == cells[name]
        elif name in ("integrator.t_end", "index"):
            assert [float(v) for v in values] == [float(c) for c in cells[name]]
        else:
            assert_cells_equal(cells[res.header(name)], values, name)


def test_sweep_equals_the_cli(tmp_path: Path, monkeypatch: pytest.MonkeyPatch, root: Path) -> None:
    monkeypatch.chdir(root)
    cli("sweep", "scenarios/damper.toml", "--set", "mechanism.half_angle_deg=30,40,50", "--set",
        "generator.load_resistance=2,8", "-o", str(tmp_path), "--quiet")
    res = damper.Scenario.load("scenarios/damper.toml").sweep(
        {"mechanism.half_angle_deg": [30, 40, 50], "generator.load_resistance": [2, 8]}, threads=2
    )
    cells = read_csv(tmp_path / "sweep.csv")
    assert res.headers == list(cells)
    for name, values in res.items():
        if name in ("error", "time_domain_error"):
            assert [v or "" for v in values] == cells[name]
        elif name in ("mechanism.half_angle_deg", "generator.load_resistance", "index"):
            assert [float(v) for v in values] == [float(c) for c in cells[name]]
        else:
            assert_cells_equal(cells[res.header(name)], values, name)


def test_time_domain_sweep_keeps_the_summary_figures(monkeypatch: pytest.MonkeyPatch, root: Path) -> None:
    monkeypatch.chdir(root)
    sc = damper.Scenario.load("scenarios/damper.toml", set={"integrator.t_end": 0.5})
    res = sc.sweep({"mechanism.half_angle_deg": "40,50"}, time_domain=True)
    assert res["time_domain_error"] == [None, None]
    # The figure of the point equals the summary of the same run.
    run = sc.with_set({"mechanism.half_angle_deg": 50}).simulate()
    assert res["peak_amplitude"][1] == run.summary["peak_amplitude"]


@pytest.mark.parametrize("scenario", ["scenarios/damper.toml", "scenarios/aluminium_cantilever.toml"])
def test_optimize_equals_the_cli(scenario: str, monkeypatch: pytest.MonkeyPatch, root: Path) -> None:
    monkeypatch.chdir(root)
    expected = json.loads(
        cli("optimize", scenario, "--vary", "mechanism.half_angle_deg=3:25",
            "--maximize", "zeta1", "--constraint", "reach>=0.002", "--json").stdout
    )
    got = damper.Scenario.load(scenario).optimize(
        {"mechanism.half_angle_deg": (3, 25)}, maximize="zeta1", constraints=["reach>=0.002"]
    )
    assert got.report == expected
    with pytest.raises(ValueError, match="one of"):
        damper.Scenario.load("scenarios/damper.toml").optimize({"mechanism.half_angle_deg": (20, 70)})


@pytest.mark.parametrize("scenario", ["scenarios/random_damper.toml", "scenarios/random_base_damper.toml"])
@pytest.mark.parametrize("method", ["dense", "modal"])
def test_random_equals_the_cli(scenario: str, method: str, monkeypatch: pytest.MonkeyPatch, root: Path) -> None:
    monkeypatch.chdir(root)
    expected = json.loads(cli("random", scenario, "--method", method, "--json").stdout)
    got = damper.Scenario.load(scenario).random(method=method)
    assert got.report == expected
    tip = damper.Scenario.load(scenario).random(outputs=["1.0"], method=method)
    assert [o["name"] for o in tip["outputs"]][:2] == ["w(x=1)", "w(x=1)'"]
    with pytest.raises(ValueError, match="expected auto"):
        damper.Scenario.load(scenario).random(method="fast")


def test_figures_equal_the_cli(monkeypatch: pytest.MonkeyPatch, root: Path) -> None:
    """``Scenario.figures()`` is ``damper figures --json``, entry for entry."""
    monkeypatch.chdir(root)
    for rel in ("scenarios/forced_damper.toml", "scenarios/random_damper.toml"):
        listed = damper.Scenario.load(rel).figures()
        assert listed == json.loads(cli("figures", rel, "--json").stdout)
        names = [f["name"] for f in listed]
        assert "linear.zeta1" in names
        assert ("random.load_power" in names) == ("random" in rel)


def test_frf_band_edge_warnings_reach_python(tmp_path: Path, monkeypatch: pytest.MonkeyPatch, root: Path) -> None:
    """The band 7-12 Hz lies above the damper's first mode (5.94 Hz): the largest |H| of both
    responses is at the first frequency. The command line prints two `warning:` lines;
    Python issues the same texts as `DamperWarning`s with the file and the response; a band
    around the mode gives neither."""
    monkeypatch.chdir(root)
    args = ["scenarios/damper.toml", "--output", "1.0", "--from", "7", "--to", "12", "--points", "30"]
    run = cli("frf", *args, "-o", str(tmp_path / "edge"))
    lines = [l for l in run.stderr.splitlines() if l.startswith("warning: ")]
    assert len(lines) == 2, run.stderr
    sc = damper.Scenario.load("scenarios/damper.toml")
    with pytest.warns(damper.DamperWarning) as caught:
        sc.frf(1.0, 7.0, 12.0, points=30)
    got = [w for w in caught if issubclass(w.category, damper.DamperWarning)]
    assert [str(w.message) for w in got] == [l[len("warning: "):] for l in lines]
    assert [w.message.entity for w in got] == ["|H| with generator", "|H| generator disconnected"]
    assert all(w.message.file == "scenarios/damper.toml" for w in got)
    assert issubclass(damper.DamperWarning, UserWarning)
    # Attributed to the caller (this file), not to the package's wrapper.
    assert all(Path(w.filename).name == "test_linear.py" for w in got)
    quiet = cli("frf", "scenarios/damper.toml", "--output", "1.0", "--from", "2", "--to", "12", "--points", "30",
                "-o", str(tmp_path / "inside"))
    assert "warning:" not in quiet.stderr
    import warnings

    with warnings.catch_warnings():
        warnings.simplefilter("error", damper.DamperWarning)
        sc.frf(1.0, 2.0, 12.0, points=30)


def test_a_support_motion_along_a_direction_reaches_python(tmp_path: Path, monkeypatch: pytest.MonkeyPatch, root: Path) -> None:
    """`at = "base", direction = [...]` on the frame: Python's frf equals the command line's
    cell for cell, and the direction is taken (along x and along y the girder's node responds
    differently)."""
    monkeypatch.chdir(root)
    text = (root / "scenarios/frame.toml").read_text()
    text = text.replace('"frame/', f'"{root}/scenarios/frame/').replace('"../models/', f'"{root}/models/')
    force = "at = { node = 741, direction = [1.0, 0.0] }"
    assert force in text
    along_x = tmp_path / "base_x.toml"
    along_x.write_text(text.replace(force, 'at = "base"\ndirection = [1.0, 0.0]'))
    along_y = tmp_path / "base_y.toml"
    along_y.write_text(text.replace(force, 'at = "base"\ndirection = [0.0, 1.0]'))
    out = tmp_path / "frf_x"
    cli("frf", str(along_x), "--output", "613:ux", "--from", "30", "--to", "45", "--points", "20", "-o", str(out))
    cols = damper.Scenario.load(str(along_x)).frf("613:ux", 30.0, 45.0, points=20)
    cells = read_csv(out / "frf.csv")
    assert cols.headers == list(cells)
    for name, values in cols.items():
        assert_cells_equal(cells[cols.header(name)], values, f"base along x {name}")
    other = damper.Scenario.load(str(along_y)).frf("613:ux", 30.0, 45.0, points=20)
    key = cols.columns[1]  # |H| with the generator
    x, y = np.asarray(cols[key]), np.asarray(other[key])
    assert np.all(np.isfinite(x)) and np.all(np.isfinite(y))
    assert np.max(np.abs(x - y)) > 0.1 * np.max(np.abs(x))
