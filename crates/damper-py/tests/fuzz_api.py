"""The command-line mutation corpus replayed through the Python API.

The bundled scenario and model files are mutated as `crates/codegen-cli/tests/it/fuzz.rs`
mutates them (token deletion, duplication, replacement by extreme numbers, type changes,
long strings, unicode), plus the regression corpus of that harness, and given to the
package: ``Scenario.from_str`` (the loader), then ``linearize`` and a short ``simulate`` of
a scenario that loads; ``Model.load`` and ``Model.evaluate`` of a model. Every case must
return, or raise a documented exception (``ScenarioError``, ``ModelError``,
``DamperError`` and its subclasses, ``ValueError``, ``TypeError``), within ``CASE_LIMIT`` seconds.

The cases run in a child process that reports each case's start and outcome on a pipe; the
parent is the watchdog: a case that does not end within its limit is a *hang* (the child is
killed), a child that dies in a case is a *crash*; either way the run goes on with the next
case in a new child. Cases are drawn from ``random.Random(f"{seed}:{index}")``: a case is
the same on every run of a seed.

Run as a script for a long run: ``python fuzz_api.py --cases 5000 [--seed S]`` (default: a
fresh seed, printed) prints the count of each outcome and exits non-zero when any case
crashed, hung or raised an undocumented exception.
"""

from __future__ import annotations

import argparse
import json
import math
import os
import random
import subprocess
import sys
import tempfile
import time
from collections import Counter
from pathlib import Path
from typing import Any, Dict, List, Optional, Tuple

ROOT = Path(__file__).resolve().parents[3]
# The inputs and replacement tokens of the command line's harness (`fuzz.rs`), the same
# corpus on purpose.
SCENARIOS = [
    "scenarios/damper.toml",
    "scenarios/four_bar.toml",
    "scenarios/slider_crank.toml",
    "scenarios/two_dampers.toml",
    "scenarios/pendulum_absorber.toml",
    "scenarios/slider_crank_damper.toml",
    "scenarios/forced_damper.toml",
]
MODELS = ["models/double_bar.toml", "models/four_bar.toml", "models/slider_crank.toml"]
CORPUS = ROOT / "crates" / "codegen-cli" / "tests" / "fixtures" / "fuzz_regressions"
REPLACEMENTS = [
    "0", "-1", "1e308", "-1e308", "5e-324", "1e300", "nan", "inf", "-inf", "1e-12", "1e9",
    '"x"', "[]", "{}", "true", '"mechanizm"', '"é漢🦀\u202e"', "=", "[[bodies]]", '"\\u0000"',
    "9999999999999999999999", '"LONG"',
]
# Time limit of one case (s): a case takes milliseconds to a second; only a hang trips it.
CASE_LIMIT = 30.0
# The documented exceptions of the package.
DOCUMENTED = (
    "ScenarioError",
    "ModelError",
    "DamperError",
    "SingularPosition",
    "ArgumentError",
    "UnknownName",
    "NotAvailable",
    "NumericalError",
    "OptimizationError",
    "MergeError",
    "ResourceError",
    "WorkLimitError",
    "SimulationError",
    "ValueError",
    "TypeError",
)
# Outcomes that fail the run.
FAILURES = ("crash", "hang", "undocumented", "non-finite", "empty")


def tokens(text: str) -> List[str]:
    """Tokens that keep the separators (whitespace and ``,[]{}=``)."""
    out: List[str] = []
    cur = ""
    for c in text:
        if c.isspace() or c in ",[]{}=":
            if cur:
                out.append(cur)
                cur = ""
            out.append(c)
        else:
            cur += c
    if cur:
        out.append(cur)
    return out


def mutate(text: str, rng: random.Random) -> str:
    """One to four edits of the token list."""
    t = tokens(text)
    for _ in range(rng.randint(1, 4)):
        if not t:
            break
        i = rng.randrange(len(t))
        kind = rng.randrange(3)
        if kind == 0:
            del t[i]
        elif kind == 1:
            t.insert(i, t[i])
        else:
            r = rng.choice(REPLACEMENTS)
            t[i] = '"' + "w" * 70_000 + '"' if r == '"LONG"' else r
    return "".join(t)


def case(seed: str, index: int) -> Tuple[str, str, List[Tuple[str, str]]]:
    """Case ``index`` of ``seed``: (kind, text, sets); the corpus files first."""
    corpus = sorted(CORPUS.glob("*.toml")) if CORPUS.is_dir() else []
    if index < len(corpus):
        text = corpus[index].read_text()
        kind = "model" if corpus[index].name.startswith("model-") else "scenario"
        sets = [tuple(s.strip().split("=", 1)) for s in (line[len("# fuzz-set:"):] for line in text.splitlines() if line.startswith("# fuzz-set:"))]
        return kind, text, [(k, v) for k, v in sets]  # type: ignore[misc]
    rng = random.Random(f"{seed}:{index}")
    if rng.random() < 0.8:
        return "scenario", mutate((ROOT / rng.choice(SCENARIOS)).read_text(), rng), []
    return "model", mutate((ROOT / rng.choice(MODELS)).read_text(), rng), []


def run_case(kind: str, text: str, sets: List[Tuple[str, str]], tmp: Path) -> str:
    """One case through the API: its outcome."""
    import damper

    try:
        if kind == "scenario":
            sc = damper.Scenario.from_str(text, base_dir=ROOT / "scenarios", name="fuzz_scenario.toml")
            if sets:
                sc = sc.with_set(dict(sets))
            if sc.kind == "hybrid":
                lin = sc.linearize(modes=2)
                if not all(math.isfinite(m.natural_frequency_hz) for m in lin.modes):
                    return "non-finite"
            # A short run: the mutated file was loaded as written; the run's length is
            # the budget's business (tested on its own), not the fuzz's.
            run = sc.with_set({"integrator.t_end": 0.02}).simulate(compare=[] if sc.kind == "hybrid" else None)
            if len(run) == 0:
                return "empty"
        else:
            path = tmp / "fuzz_model.toml"
            path.write_text(text)
            model = damper.Model.load(path)
            n = len(model.coordinates)
            if n:
                model.evaluate([0.1] * n, [0.0] * n)
        return "ok"
    except Exception as e:  # noqa: BLE001 - every exception is classified
        name = type(e).__name__
        return name if name in DOCUMENTED else f"undocumented:{name}: {str(e)[:200]}"


def child(seed: str, start: int, stop: int) -> None:
    """Runs cases ``start..stop`` and reports ``START i`` and ``END i outcome`` lines."""
    with tempfile.TemporaryDirectory() as tmp:
        for i in range(start, stop):
            print(f"START {i}", flush=True)
            kind, text, sets = case(seed, i)
            print(f"END {i} {json.dumps(run_case(kind, text, sets, Path(tmp)))}", flush=True)


def _readline(proc: subprocess.Popen, deadline: float) -> Optional[str]:
    """The child's next line before ``deadline`` ("" at its end, None at the deadline)."""
    import select

    assert proc.stdout is not None
    while True:
        left = deadline - time.monotonic()
        if left <= 0:
            return None
        ready, _, _ = select.select([proc.stdout], [], [], left)
        if ready:
            return proc.stdout.readline()


def run(seed: str, cases: int, limit: float = CASE_LIMIT) -> Tuple[Counter, Dict[str, List[int]]]:
    """Runs ``cases`` cases of ``seed`` under the watchdog: the count of each outcome and
    the failing cases by outcome."""
    counts: Counter = Counter()
    failing: Dict[str, List[int]] = {}
    next_case = 0
    while next_case < cases:
        proc = subprocess.Popen(
            [sys.executable, __file__, "--child", "--seed", seed, "--start", str(next_case), "--stop", str(cases)],
            stdout=subprocess.PIPE,
            stderr=subprocess.DEVNULL,
            text=True,
            cwd=ROOT,
        )
        current: Optional[int] = None
        while True:
            line = _readline(proc, time.monotonic() + limit)
            if line is None or line == "":
                outcome = "hang" if line is None else "crash"
                proc.kill()
                proc.wait()
                if current is not None:
                    counts[outcome] += 1
                    failing.setdefault(outcome, []).append(current)
                    next_case = current + 1
                elif line == "":
                    raise RuntimeError("the fuzz child died before its first case")
                break
            word, index, *rest = line.split(" ", 2)
            if word == "START":
                current = int(index)
            elif word == "END":
                outcome = json.loads(rest[0])
                key = "undocumented" if outcome.startswith("undocumented") else outcome
                counts[key] += 1
                if key in FAILURES:
                    failing.setdefault(key, []).append(int(index))
                    print(f"case {index}: {outcome}", file=sys.stderr)
                current = None
                next_case = int(index) + 1
                if next_case >= cases:
                    proc.wait()
                    break
    return counts, failing


def main() -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--cases", type=int, default=5000)
    p.add_argument("--seed", default=None)
    p.add_argument("--child", action="store_true", help=argparse.SUPPRESS)
    p.add_argument("--start", type=int, default=0, help=argparse.SUPPRESS)
    p.add_argument("--stop", type=int, default=0, help=argparse.SUPPRESS)
    a = p.parse_args()
    if a.child:
        child(a.seed, a.start, a.stop)
        return 0
    seed = a.seed or os.urandom(8).hex()
    print(f"seed {seed}, {a.cases} cases", flush=True)
    t0 = time.monotonic()
    counts, failing = run(seed, a.cases)
    print(f"{time.monotonic() - t0:.0f} s")
    for outcome, n in sorted(counts.items(), key=lambda kv: -kv[1]):
        print(f"{outcome:>20} {n}")
    for outcome, cases in failing.items():
        print(f"{outcome}: cases {cases[:20]}")
    return 1 if failing else 0


if __name__ == "__main__":
    sys.exit(main())
