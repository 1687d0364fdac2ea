"""A sweep beyond one process: the grid's points (`Scenario.sweep_points`), its shards
evaluated in other processes (the scenario pickled to them, each `SweepPart` pickled back)
and joined by `merge_sweep` — the table of `damper sweep`'s `sweep.csv` cell for cell; the
parts merged by `damper merge` into the same `sweep.csv` byte for byte; the dask example
(`examples/sweep_dask.py`) on a local cluster; and the merge's refusals."""

from __future__ import annotations

import concurrent.futures
import os
import pickle
import runpy
import subprocess
import sys
from pathlib import Path
from typing import Any, Dict

import pytest

import damper
from conftest import cli, read_csv
from test_results import assert_table_equals_csv

EXAMPLE = Path(__file__).resolve().parents[1] / "examples" / "sweep_dask.py"
AXES = {"mechanism.half_angle_deg": [30, 40, 50], "generator.load_resistance": "2:8:2"}


def shard(sc: damper.Scenario, k: int, n: int) -> damper.SweepPart:
    return sc.sweep_shard(AXES, k, n, threads=1)


@pytest.fixture()
def sc(monkeypatch: pytest.MonkeyPatch, root: Path) -> damper.Scenario:
    monkeypatch.chdir(root)
    return damper.Scenario.load("scenarios/damper.toml")


def cli_sweep(out: Path, axes: Dict[str, Any]) -> Path:
    sets = []
    for path, values in axes.items():
        text = values if isinstance(values, str) else ",".join(str(v) for v in values)
        sets += ["--set", f"{path}={text}"]
    cli("sweep", "scenarios/damper.toml", *sets, "-o", str(out), "--quiet")
    return out / "sweep.csv"


def test_the_points_are_the_grid_in_order(sc: damper.Scenario) -> None:
    points = sc.sweep_points(AXES)
    assert points == [
        {"mechanism.half_angle_deg": a, "generator.load_resistance": r} for a in (30, 40, 50) for r in (2, 8)
    ]
    whole = sc.sweep(AXES)
    assert [whole["mechanism.half_angle_deg"][i] for i in range(len(whole))] == [p["mechanism.half_angle_deg"] for p in points]
    with pytest.raises(damper.WorkLimitError, match="--allow-long"):
        sc.sweep_points({"mechanism.half_angle_deg": "1:2:1000", "generator.load_resistance": "1:2:1000"})


def test_shards_in_other_processes_give_the_cli_table(sc: damper.Scenario, tmp_path: Path) -> None:
    csv = cli_sweep(tmp_path / "cli", AXES)
    n = len(sc.sweep_points(AXES))  # one point per shard
    with concurrent.futures.ProcessPoolExecutor(max_workers=2) as pool:
        parts = list(pool.map(shard, [sc] * n, range(n), [n] * n))
    assert all(pickle.loads(pickle.dumps(p)) == p for p in parts)
    merged = damper.merge_sweep(reversed(parts))
    assert_table_equals_csv(merged, read_csv(csv), "merged shards")
    assert merged == sc.sweep(AXES)
    # The parts are the command line's part files: `damper merge` writes the same sweep.csv.
    for p in parts:
        p.write(tmp_path / "parts")
    cli("merge", str(tmp_path / "parts"))
    assert (tmp_path / "parts" / "sweep.csv").read_bytes() == csv.read_bytes()


def test_a_bad_set_of_parts_is_refused_naming_the_part(sc: damper.Scenario) -> None:
    parts = [sc.sweep_shard(AXES, k, 3) for k in range(3)]
    with pytest.raises(damper.MergeError, match=r"missing shard\(s\) of 3: sweep.part-2-of-3.json"):
        damper.merge_sweep(parts[:2])
    with pytest.raises(damper.MergeError, match="given twice"):
        damper.merge_sweep(parts + parts[:1])
    edited = parts[0].text.replace('"index": 0', '"index": 3', 1)
    with pytest.raises(damper.MergeError, match="checksum|not in shard"):
        damper.merge_sweep([edited, parts[1], parts[2]])
    other = sc.with_set({"integrator.t_end": 0.3}).sweep_shard(AXES, 2, 3)
    with pytest.raises(damper.MergeError, match="parts of different sweeps"):
        damper.merge_sweep(parts[:2] + [other])
    with pytest.raises(damper.MergeError, match="not a complete sweep part file"):
        damper.merge_sweep(["{}"])
    with pytest.raises(TypeError, match="SweepPart"):
        damper.merge_sweep([b"{}"])  # type: ignore[list-item]
    with pytest.raises(damper.ArgumentError, match="shard") as e:
        sc.sweep_shard(AXES, 3, 3)
    assert e.value.option == "--shard"


def test_the_dask_example_gives_the_cli_table(sc: damper.Scenario, tmp_path: Path, root: Path) -> None:
    pytest.importorskip("dask.distributed")
    example = runpy.run_path(str(EXAMPLE))
    axes = example["AXES"]
    csv = cli_sweep(tmp_path / "cli", axes)
    sweep, parts = example["sweep_on_dask"](sc, shards=3)
    assert_table_equals_csv(sweep, read_csv(csv), "dask sweep")
    # The script itself: its part files merge into the same sweep.csv, byte for byte.
    out = tmp_path / "parts"
    r = subprocess.run([sys.executable, str(EXAMPLE), str(out)], cwd=root, capture_output=True, text=True,
                       env={**os.environ, "MPLBACKEND": "Agg"}, timeout=600)
    assert r.returncode == 0, r.stderr
    assert len(list(out.glob("sweep.part-*-of-4.json"))) == 4
    cli("merge", str(out))
    assert (out / "sweep.csv").read_bytes() == csv.read_bytes()


def test_the_guides_show_the_dask_example(root: Path) -> None:
    code = EXAMPLE.read_text().split('"""', 2)[2].strip()
    for page in ("python.md", "sweeps.md"):
        text = (root / "docs" / "guide" / page).read_text()
        indented = "\n".join(("    " + l) if l else "" for l in code.splitlines())
        assert code in text or indented in text, page
