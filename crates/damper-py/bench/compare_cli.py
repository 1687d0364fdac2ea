"""Wall time of the Python package against the `damper` binary (a measurement, not a test).

From the repository root, with the package installed (scripts/test builds it into
target/py-venv):

    target/py-venv/bin/python crates/damper-py/bench/compare_cli.py [REPEATS]

Two jobs: the paper's damper simulated for 5 s (with its two comparison runs), and a
100-point linear sweep of its half-angle. For each: the CLI process, the same job as a
whole Python process (`python -c`, interpreter start and import included) and the call
inside a running interpreter; best and median of REPEATS runs, each job alternating the
three so that machine load hits them alike.
"""

from __future__ import annotations

import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import damper

BIN = "target/release/damper"
JOBS = {
    "simulate scenarios/damper.toml (5 s)": (
        lambda out: [BIN, "simulate", "scenarios/damper.toml", "-o", out, "--quiet"],
        "import damper; damper.Scenario.load('scenarios/damper.toml').simulate()",
        lambda: damper.Scenario.load("scenarios/damper.toml").simulate(),
    ),
    "sweep of 100 half-angles (linear)": (
        lambda out: [BIN, "sweep", "scenarios/damper.toml", "--set", "mechanism.half_angle_deg=3:25:100", "-o", out, "--quiet"],
        "import damper; damper.Scenario.load('scenarios/damper.toml').sweep({'mechanism.half_angle_deg': '3:25:100'})",
        lambda: damper.Scenario.load("scenarios/damper.toml").sweep({"mechanism.half_angle_deg": "3:25:100"}),
    ),
}


def timed(f) -> float:
    t = time.perf_counter()
    f()
    return time.perf_counter() - t


def main() -> None:
    repeats = int(sys.argv[1]) if len(sys.argv) > 1 else 7
    for name, (cli, script, call) in JOBS.items():
        times: dict = {"CLI process": [], "Python process": [], "Python call": []}
        for _ in range(repeats):
            with tempfile.TemporaryDirectory() as d:
                times["CLI process"].append(timed(lambda: subprocess.run(cli(d), check=True, capture_output=True)))
            times["Python process"].append(timed(lambda: subprocess.run([sys.executable, "-c", script], check=True)))
            times["Python call"].append(timed(call))
        print(name)
        base = min(times["CLI process"])
        for k, v in times.items():
            print(f"  {k:15s} best {min(v):.3f} s  median {statistics.median(v):.3f} s  (best / CLI best {min(v) / base:.2f})")


if __name__ == "__main__":
    main()
