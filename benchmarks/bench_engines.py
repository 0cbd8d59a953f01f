"""Ray against Dask for campaigns (docs/design/alternatives.md, "Dask rather than Ray"): a local cluster of 2 workers on 127.0.0.1,
started, given 200 empty tasks and a few real short flights (the campaign's own fly_point), stopped; prints the
medians of the start, per-task and stop times, the memory of the cluster's processes and the flights per minute.

    python benchmarks/bench_engines.py [--repeats 3] [--flights 4]

Ray is not a dependency of the project: install it (`pip install ray`) to measure it; an engine that is not
installed is skipped.
"""

from __future__ import annotations

import argparse
import logging
import os
import statistics
import tempfile
import time
from pathlib import Path

import psutil

from ground_tools.campaign.points import FlightPoint, point_key

WORKERS = 2
EMPTY_TASKS = 200


def nothing(i: int) -> int:
    return i


def _flights(count: int) -> list[FlightPoint]:
    params = {"duration_s": 0.5}
    return [FlightPoint(point_key("accel", params, "pid", r), "accel", "pid", r, params) for r in range(count)]


def _cluster_rss_mb() -> float:
    me = psutil.Process(os.getpid())
    processes = [me, *me.children(recursive=True)]
    return sum(p.memory_info().rss for p in processes if p.is_running()) / 1e6


def dask_round(flights: int, out: str) -> dict[str, float]:
    from dask.distributed import Client, LocalCluster

    from ground_tools.campaign.flight import fly_point

    started = time.perf_counter()
    cluster = LocalCluster(n_workers=WORKERS, threads_per_worker=1, processes=True, host="127.0.0.1",
                           dashboard_address=None, silence_logs=logging.ERROR)  # fmt: skip
    client = Client(cluster)
    client.gather(client.map(nothing, range(WORKERS), pure=False))
    result = {"start_s": time.perf_counter() - started, "rss_mb": _cluster_rss_mb()}
    t = time.perf_counter()
    client.gather(client.map(nothing, range(EMPTY_TASKS), pure=False))
    result["task_ms"] = (time.perf_counter() - t) / EMPTY_TASKS * 1000
    t = time.perf_counter()
    rows = client.gather(client.map(fly_point, _flights(flights), out=out, campaign_folder=out, pure=False))
    result["flights_per_min"] = flights / (time.perf_counter() - t) * 60
    assert all(row["status"] == "done" for row in rows), rows
    t = time.perf_counter()
    client.close()
    cluster.close()
    result["stop_s"] = time.perf_counter() - t
    return result


def ray_round(flights: int, out: str) -> dict[str, float]:
    import ray

    from ground_tools.campaign.flight import fly_point

    started = time.perf_counter()
    ray.init(num_cpus=WORKERS, include_dashboard=False, logging_level=logging.ERROR, log_to_driver=False,
             _node_ip_address="127.0.0.1")  # fmt: skip
    remote_nothing, remote_fly = ray.remote(nothing), ray.remote(fly_point)
    ray.get([remote_nothing.remote(i) for i in range(WORKERS)])
    result = {"start_s": time.perf_counter() - started, "rss_mb": _cluster_rss_mb()}
    t = time.perf_counter()
    ray.get([remote_nothing.remote(i) for i in range(EMPTY_TASKS)])
    result["task_ms"] = (time.perf_counter() - t) / EMPTY_TASKS * 1000
    t = time.perf_counter()
    rows = ray.get([remote_fly.remote(point, out, out) for point in _flights(flights)])
    result["flights_per_min"] = flights / (time.perf_counter() - t) * 60
    assert all(row["status"] == "done" for row in rows), rows
    t = time.perf_counter()
    ray.shutdown()
    result["stop_s"] = time.perf_counter() - t
    return result


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument("--flights", type=int, default=4)
    args = parser.parse_args()
    rounds = {"dask": dask_round, "ray": ray_round}
    for name, round_ in rounds.items():
        try:
            __import__(name)
        except ImportError:
            print(f"{name}: not installed, skipped")
            continue
        results = []
        for _ in range(args.repeats):
            with tempfile.TemporaryDirectory() as out:
                results.append(round_(args.flights, str(Path(out))))
        medians = {key: statistics.median(r[key] for r in results) for key in results[0]}
        print(
            f"{name}: start {medians['start_s']:.2f} s, stop {medians['stop_s']:.2f} s, "
            f"{medians['task_ms']:.2f} ms per empty task, cluster memory {medians['rss_mb']:.0f} MB, "
            f"{medians['flights_per_min']:.1f} flights/min ({args.flights} flights of 0.5 s, PID, {WORKERS} workers; "
            f"medians of {args.repeats})",
            flush=True,
        )


if __name__ == "__main__":
    main()
