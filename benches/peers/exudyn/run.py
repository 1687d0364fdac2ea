#!/usr/bin/env python3
"""The paper's damper, `damper simulate` against Exudyn (damper.py): agreement and timing.

  run.py agree [--dt DT ...]   trajectories of both at each step size, largest differences
  run.py time  [--runs N]      whole-process wall times, the two interleaved, medians and ratio

See benches/peers/README.md (section Exudyn). A measurement, not a test.
"""
import argparse
import csv
import math
import os
import shutil
import statistics
import subprocess
import sys
import tempfile
import time

HERE = os.path.dirname(os.path.abspath(__file__))
REPO = os.path.normpath(os.path.join(HERE, "..", "..", ".."))
SCENARIO = os.path.join(REPO, "scenarios", "damper.toml")
VENV_PY = os.path.join(REPO, "target", "exu-venv", "bin", "python")
COLUMNS = ["pin.w [m]", "pin.w_dot [m/s]", "damper.q1 [rad]", "damper.q2 [rad]",
           "damper.q1_dot [rad/s]", "generator.current [A]"]


def fail(msg):
    sys.exit(f"run.py: {msg}")


def check_tools(args):
    if not (os.path.isfile(args.damper) and os.access(args.damper, os.X_OK)):
        fail(f"{args.damper}: no damper binary (cargo build --release -p codegen-cli, or --damper PATH)")
    if not (os.path.isfile(args.python) and os.access(args.python, os.X_OK)):
        fail(f"{args.python}: no Python of the Exudyn venv (benches/peers/README.md, or --python PATH)")


def ours_cmd(args, out, dt=None, every=None, t_end=None):
    cmd = [args.damper, "simulate", SCENARIO, "--set", "output.compare=[]", "-o", out, "--quiet"]
    if dt is not None:
        cmd += ["--set", f"integrator.dt={dt!r}"]
    if every is not None:
        cmd += ["--set", f"output.every={every}"]
    if t_end is not None:
        cmd += ["--set", f"integrator.t_end={t_end!r}"]
    return cmd


def exu_cmd(args, out, dt=None, every=None, t_end=None, csv_path=None):
    cmd = [args.python, os.path.join(HERE, "damper.py"), SCENARIO, "--quiet"]
    if out:
        cmd += ["-o", out]
    if dt is not None:
        cmd += ["--dt", repr(dt)]
    if every is not None:
        cmd += ["--every", str(every)]
    if t_end is not None:
        cmd += ["--t-end", repr(t_end)]
    if csv_path:
        cmd += ["--csv", csv_path]
    return cmd + args.exu_args.split()


def read_csv(path):
    with open(path, newline="") as f:
        rows = list(csv.reader(f))
    head = rows[0]
    cols = {h: i for i, h in enumerate(head)}
    data = {h: [float(r[cols[h]]) for r in rows[1:] if r[cols[h]] != ""] for h in head}
    return data


def run(cmd):
    p = subprocess.run(cmd, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    if p.returncode != 0:
        fail(f"{' '.join(cmd)} exited with {p.returncode}: {p.stderr.strip().splitlines()[-1:]}")
    return p.stderr


def agree(args):
    check_tools(args)
    t_end = args.t_end
    print(f"largest difference over 0..{t_end:g} s, relative to the column's largest |value| "
          f"in damper's run (rows every {args.sample:g} s)")
    print("| dt [s] | " + " | ".join(COLUMNS) + " |")
    print("| --- |" + " --- |" * len(COLUMNS))
    drifts = []
    with tempfile.TemporaryDirectory(prefix="exu-agree-") as tmp:
        for dt in args.dt:
            every = max(1, round(args.sample / dt))
            ours = os.path.join(tmp, f"ours-{dt:g}")
            theirs = os.path.join(tmp, f"exu-{dt:g}.csv")
            run(ours_cmd(args, ours, dt=dt, every=every, t_end=t_end))
            drift = run(exu_cmd(args, "", dt=dt, every=every, t_end=t_end, csv_path=theirs))
            a = read_csv(os.path.join(ours, "time_history.csv"))
            b = read_csv(theirs)
            n = min(len(a["t [s]"]), len(b["t [s]"]))
            if n < 2:
                fail("no rows to compare")
            dtmax = max(abs(a["t [s]"][k] - b["t [s]"][k]) for k in range(n))
            if dtmax > 1e-9:
                fail(f"the rows' times differ by {dtmax:g} s")
            cells = []
            for c in COLUMNS:
                amp = max(abs(x) for x in a[c][:n])
                if c in ("damper.q1 [rad]", "damper.q2 [rad]"):
                    # angles: relative to the largest excursion from the initial value
                    amp = max(abs(x - a[c][0]) for x in a[c][:n])
                diff = max(abs(a[c][k] - b[c][k]) for k in range(n))
                cells.append(f"{diff / amp:.2e}")
            print(f"| {dt:g} | " + " | ".join(cells) + " |", flush=True)
            drifts.append(f"dt {dt:g}: exudyn's " + drift.strip())
    print("(q1, q2: relative to their largest excursion from the initial angle)")
    for d in drifts:
        print(d)


def run_timed(cmd):
    """Wall seconds (monotonic clock around start and reap) and the child's user + system
    CPU seconds (the kernel's accounting, os.wait4)."""
    t0 = time.perf_counter()
    p = subprocess.Popen(cmd, stdin=subprocess.DEVNULL, stdout=subprocess.DEVNULL,
                         stderr=subprocess.PIPE)
    err = p.stderr.read()
    _, status, ru = os.wait4(p.pid, 0)
    wall = time.perf_counter() - t0
    p.returncode = os.waitstatus_to_exitcode(status)
    if p.returncode != 0:
        fail(f"{cmd[0]} exited with {p.returncode}: {err.decode(errors='replace').strip()[-300:]}")
    return wall, ru.ru_utime + ru.ru_stime


def timing(args):
    check_tools(args)
    names = ["damper simulate", "exudyn damper.py", "python -c 'import numpy, exudyn'"]
    wall = {n: [] for n in names}
    cpu = {n: [] for n in names}
    ratios, cpu_ratios = [], []
    with tempfile.TemporaryDirectory(prefix="exu-time-") as tmp:
        o = os.path.join(tmp, "ours")
        e = os.path.join(tmp, "exu")
        cmds = [(names[0], ours_cmd(args, o), o), (names[1], exu_cmd(args, e), e),
                (names[2], [args.python, "-c", "import numpy, exudyn"], None)]
        for n, c, _ in cmds:
            print(f"{n}: " + " ".join(c).replace(tmp, "TMP"))
        for k in range(args.warmup + args.runs):
            got = {}
            for n, c, d in cmds:
                if d:
                    shutil.rmtree(d, ignore_errors=True)
                got[n] = run_timed(c)
            if k >= args.warmup:
                for n in names:
                    wall[n].append(got[n][0])
                    cpu[n].append(got[n][1])
                ratios.append(got[names[1]][0] / got[names[0]][0])
                cpu_ratios.append(got[names[1]][1] / got[names[0]][1])
                print(f"run {k - args.warmup + 1}: " + ", ".join(
                    f"{n.split()[0]} {got[n][0]:.3f} s" for n in names[:2]),
                    file=sys.stderr, flush=True)
    med = statistics.median
    print(f"whole process, {args.runs} interleaved runs each, seconds (min / median / max):")
    print("| command | wall | user + system CPU |")
    print("| --- | --- | --- |")
    for n in names:
        w, c = wall[n], cpu[n]
        print(f"| {n} | {min(w):.3f} / {med(w):.3f} / {max(w):.3f} | "
              f"{min(c):.3f} / {med(c):.3f} / {max(c):.3f} |")
    print(f"ratio exudyn / damper, median of the pairs: wall {med(ratios):.1f} "
          f"(min {min(ratios):.1f}, max {max(ratios):.1f}), CPU {med(cpu_ratios):.1f} "
          f"(min {min(cpu_ratios):.1f}, max {max(cpu_ratios):.1f})")


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--damper", default=os.path.join(REPO, "target", "release", "damper"),
                    help="the damper binary (default target/release/damper)")
    ap.add_argument("--exu-args", default="", metavar="'ARGS'",
                    help="more arguments for damper.py, e.g. '--rho 0.9'")
    ap.add_argument("--python", default=VENV_PY,
                    help="Python with exudyn and numpy (default target/exu-venv/bin/python)")
    sub = ap.add_subparsers(dest="what", required=True)
    g = sub.add_parser("agree", help="compare the trajectories at each step size")
    g.add_argument("--dt", type=float, nargs="+", default=[1e-4, 5e-5, 2.5e-5])
    g.add_argument("--t-end", type=float, default=5.0)
    g.add_argument("--sample", type=float, default=1e-3, help="row spacing compared (s)")
    t = sub.add_parser("time", help="whole-process times, interleaved")
    t.add_argument("--runs", type=int, default=10)
    t.add_argument("--warmup", type=int, default=1)
    args = ap.parse_args()
    if args.what == "agree":
        agree(args)
    else:
        if not 1 <= args.runs <= 100 or not 0 <= args.warmup <= 10:
            fail("--runs 1..100, --warmup 0..10")
        timing(args)


if __name__ == "__main__":
    main()
