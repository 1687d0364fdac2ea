"""Shared fixtures: the repository, the `damper` binary the Python results are compared
with, and a runner of that binary."""

from __future__ import annotations

import csv
import json
import math
import os
import subprocess
from pathlib import Path
from typing import Any, Dict, List

import pytest

ROOT = Path(__file__).resolve().parents[3]
BINARY = Path(os.environ.get("DAMPER_BIN", ROOT / "target" / "release" / "damper"))
SCENARIOS = sorted((ROOT / "scenarios").glob("*.toml"))
MODELS = sorted(p for p in (ROOT / "models").iterdir() if p.suffix in (".toml", ".json"))

# Wall-clock figures differ between any two runs.
WALL = {"wall_seconds", "steps_per_second", "wall_time_s"}
# The summary fields that hold a mechanism model's path.
MODEL_PATHS = {"model_file", "model"}


def cli(*args: str, check: bool = True) -> subprocess.CompletedProcess:
    """Runs the `damper` binary from the repository root."""
    assert BINARY.exists(), f"{BINARY} is missing: cargo build --release -p codegen-cli"
    return subprocess.run([str(BINARY), *args], cwd=ROOT, capture_output=True, text=True, check=check)


def without_wall(v: Any) -> Any:
    """`v` with the wall-clock fields removed at every level, and every model path
    (`model_file`, a mechanism scenario's `model`) as an absolute path (the command line's, run from the repository root, relative to it; a
    Python scenario keeps its directory as an absolute path)."""
    if isinstance(v, dict):
        return {
            k: os.path.normpath(os.path.join(ROOT, x)) if k in MODEL_PATHS and isinstance(x, str) else without_wall(x)
            for k, x in v.items()
            if k not in WALL
        }
    if isinstance(v, list):
        return [without_wall(x) for x in v]
    return v


def read_csv(path: Path) -> Dict[str, List[str]]:
    """The columns of a CSV as its cells (text)."""
    with open(path, newline="") as f:
        rows = list(csv.reader(f))
    header, body = rows[0], rows[1:]
    return {h: [r[i] for r in body] for i, h in enumerate(header)}


def assert_cells_equal(cells: List[str], values: Any, what: str) -> None:
    """Every CSV cell reads back to the array's number exactly (an empty cell: not finite)."""
    assert len(cells) == len(values), f"{what}: {len(cells)} rows in the CSV, {len(values)} in Python"
    for i, (c, x) in enumerate(zip(cells, values)):
        if c == "":
            assert not math.isfinite(x), f"{what}[{i}]: empty cell, Python {x}"
        else:
            assert float(c) == x, f"{what}[{i}]: CSV {c}, Python {x!r}"


def load_json(path: Path) -> Any:
    with open(path) as f:
        return json.load(f)


@pytest.fixture(scope="session")
def root() -> Path:
    return ROOT
