"""The package itself: the type stub matches the native module (`mypy.stubtest`), the
package type-checks, the guide's example runs (matplotlib optional: skipped when absent) and
is the one the guide's Python page shows, and the front page's Python tour runs."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

import damper

EXAMPLE = Path(__file__).resolve().parents[1] / "examples" / "sweep_half_angle.py"


def test_stub_matches_the_module() -> None:
    pytest.importorskip("mypy")
    r = subprocess.run(
        [sys.executable, "-m", "mypy.stubtest", "damper._damper"], capture_output=True, text=True
    )
    assert r.returncode == 0, r.stdout + r.stderr


def test_package_type_checks(tmp_path: Path) -> None:
    pytest.importorskip("mypy")
    r = subprocess.run(
        [sys.executable, "-m", "mypy", "--cache-dir", str(tmp_path), "-p", "damper"], capture_output=True, text=True
    )
    assert r.returncode == 0, r.stdout + r.stderr


def test_the_tests_of_the_results_type_check(tmp_path: Path) -> None:
    """The typed results as users' code sees them: the tests that use them and the
    examples, checked by mypy against the package's annotations."""
    pytest.importorskip("mypy")
    here = Path(__file__).resolve().parent
    files = [here / f for f in ("test_results.py", "test_sweep_cluster.py", "test_notebook.py")]
    files += sorted((here.parent / "examples").glob("*.py"))
    r = subprocess.run(
        [sys.executable, "-m", "mypy", "--cache-dir", str(tmp_path), "--disallow-untyped-defs", *map(str, files)],
        capture_output=True, text=True, cwd=here,
    )
    assert r.returncode == 0, r.stdout + r.stderr


def test_every_public_name_is_documented() -> None:
    for name in damper.__all__:
        obj = getattr(damper, name)
        assert obj.__doc__, name
    classes = (damper.Scenario, damper.Model, damper.Table, damper.Run, damper.FrfResult, damper.SweepResult,
               damper.RandomResult, damper.Optimum, damper.SweepPart, damper.Linearization)
    for cls in classes:
        for attr, value in vars(cls).items():
            if callable(value) and not attr.startswith("_"):
                assert value.__doc__, f"{cls.__name__}.{attr}"


def test_guide_shows_the_example(root: Path) -> None:
    readme = (root / "docs" / "guide" / "python.md").read_text()
    code = EXAMPLE.read_text()
    body = code.split('"""', 2)[2].strip()
    indented = "\n".join(("    " + l) if l else "" for l in body.splitlines())
    assert body in readme or indented in readme


def test_example_runs_and_plots(tmp_path: Path, root: Path) -> None:
    pytest.importorskip("matplotlib")
    png = tmp_path / "zeta1.png"
    r = subprocess.run(
        [sys.executable, str(EXAMPLE), str(png)], cwd=root, capture_output=True, text=True, env={**os.environ, "MPLBACKEND": "Agg"}
    )
    assert r.returncode == 0, r.stderr
    assert png.stat().st_size > 1000 and png.read_bytes()[:4] == b"\x89PNG"
    # The printed optimum is the sweep's.
    sweep = damper.Scenario.load(root / "scenarios" / "damper.toml").sweep({"mechanism.half_angle_deg": "3:25:23"})
    zeta1 = sweep["linear.zeta1"]
    best = int(np.argmax(zeta1))
    assert f"highest zeta1 = {zeta1[best]:.4f} at a half-angle of {sweep['mechanism.half_angle_deg'][best]} deg" in r.stdout


def test_front_page_python_tour_runs(root: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """Every ```python block of README.md runs from the repository root, as shown."""
    text = (root / "README.md").read_text()
    blocks = [b.split("```", 1)[0] for b in text.split("```python\n")[1:]]
    assert blocks, "README.md shows Python"
    monkeypatch.chdir(root)
    for block in blocks:
        namespace: dict[str, object] = {}
        exec(compile(block, "README.md", "exec"), namespace)
    # The tour's last block leaves a linearisation, a sweep and a run behind.
    lin = namespace["lin"]
    assert isinstance(lin, damper.Linearization)
    assert abs(lin.modes[0].natural_frequency_hz - 5.943158) < 1e-6
