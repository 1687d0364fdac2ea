"""A sweep spread over a dask.distributed cluster: the grid's shards evaluated by the
workers (`Scenario.sweep_shard`: each a `SweepPart`, a plain string that pickles), joined by
`damper.merge_sweep` into exactly the table `damper sweep` writes; the part files written
into OUT also merge with `damper merge OUT` into the command line's `sweep.csv`, byte for
byte. Run from the repository root: `python crates/damper-py/examples/sweep_dask.py [OUT]`."""

import sys

from dask.distributed import Client, LocalCluster

import damper

AXES = {"mechanism.half_angle_deg": "5:25:5", "generator.load_resistance": "1:16:5:log"}


def shard(scenario: damper.Scenario, k: int, n: int) -> damper.SweepPart:
    """Shard k of n of the sweep, on one worker thread."""
    return scenario.sweep_shard(AXES, k, n, threads=1)


def sweep_on_dask(scenario: damper.Scenario, shards: int = 4) -> "tuple[damper.SweepResult, list[damper.SweepPart]]":
    """The sweep of AXES over a local cluster of two workers, and its parts."""
    with LocalCluster(n_workers=2, threads_per_worker=1, processes=False, dashboard_address=None) as cluster:
        with Client(cluster) as client:
            futures = client.map(shard, [scenario] * shards, range(shards), [shards] * shards)
            parts = client.gather(futures)
    return damper.merge_sweep(parts), parts


if __name__ == "__main__":
    sc = damper.Scenario.load("scenarios/damper.toml")
    sweep, parts = sweep_on_dask(sc)
    print(sweep)
    best = int(sweep["linear.zeta1"].argmax())
    print(f"highest zeta1 = {sweep['linear.zeta1'][best]:.4f} at", sc.sweep_points(AXES)[best])
    if len(sys.argv) > 1:
        for p in parts:
            print("wrote", p.write(sys.argv[1]))
