"""Ctrl-C during a long `simulate` (of a damper or of a closed-loop mechanism, a long
time-domain sweep, a nonlinear frequency response): SIGINT to a Python process running it raises `KeyboardInterrupt` within a second. Deterministic: the test waits until the run's worker
thread (named `damper-worker`) exists in the child, rather than sleeping a fixed time."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

# The damper scenario run for 1000 s (a row, and a look at the stop, every 10,000 steps:
# about 0.1 s of one loaded core); the closed-loop four-bar (`kind = "mechanism"`) for
# 1e5 s.
DAMPER = ("damper.toml", '{"integrator.t_end": 1000.0, "output.every": 10000}')
FOUR_BAR = ("four_bar.toml", '{"integrator.t_end": 1e5, "integrator.output_step": 100.0}')

JOBS = {
    "simulate": (DAMPER, "sc.simulate(compare=[], allow_long=True)"),
    "time-domain sweep": (
        DAMPER,
        "sc.sweep({'mechanism.half_angle_deg': [20, 30, 40, 50]}, time_domain=True, allow_long=True)",
    ),
    # Runs that cannot settle (tolerance 1e-15) for a million periods each.
    "nonlinear frf": (
        DAMPER,
        "sc.frf(1.0, 5.0, 7.0, points=2, force=0.05, nonlinear=4, tolerance=1e-15, max_periods=10**6, allow_long=True)",
    ),
    "mechanism simulate": (FOUR_BAR, "sc.simulate(allow_long=True)"),
}

CHILD = """
import sys, time, damper
sc = damper.Scenario.load(sys.argv[1], set=SET)
print("started", flush=True)
t0 = time.perf_counter()
try:
    JOB
except KeyboardInterrupt:
    print(f"interrupted after {time.perf_counter() - t0:.3f} s", flush=True)
    sys.exit(3)
print("finished", flush=True)
"""


def worker_running(pid: int) -> bool:
    for task in Path(f"/proc/{pid}/task").iterdir():
        try:
            if (task / "comm").read_text().strip() == "damper-worker":
                return True
        except OSError:
            pass
    return False


@pytest.mark.skipif(not Path("/proc/self/task").exists(), reason="needs /proc")
@pytest.mark.parametrize("job", list(JOBS))
def test_sigint_during_a_long_call_raises_keyboard_interrupt_within_a_second(job: str, root: Path) -> None:
    (scenario, sets), call = JOBS[job]
    child = subprocess.Popen(
        [sys.executable, "-c", CHILD.replace("JOB", call).replace("SET", sets), str(root / "scenarios" / scenario)],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )
    try:
        assert child.stdout is not None
        assert child.stdout.readline().strip() == "started"
        deadline = time.monotonic() + 60
        while not worker_running(child.pid):
            assert child.poll() is None, child.communicate()
            assert time.monotonic() < deadline, "the run's worker thread never started"
            time.sleep(0.005)
        sent = time.monotonic()
        os.kill(child.pid, signal.SIGINT)
        out, err = child.communicate(timeout=30)
        elapsed = time.monotonic() - sent
    finally:
        if child.poll() is None:
            child.kill()
    assert child.returncode == 3, (out, err)
    assert "interrupted after" in out, (out, err)
    assert elapsed < 1.0, f"KeyboardInterrupt {elapsed:.3f} s after SIGINT"
