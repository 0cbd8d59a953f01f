"""`vtol campaign FILE [--out DIR] [--workers N | --address ADDR] [--report] [--no-progress]` (docs/campaigns.md).

Flies the points the store does not have yet on the engine, with a progress bar (done, failed, lost, time left),
puts each flight's row in the store as it lands, then writes the envelope report. `--report` only writes the
report from the store.
"""

from __future__ import annotations

import argparse
import os
import sys
import time
from pathlib import Path

from tqdm import tqdm

from ground_tools.campaign.engine import DaskEngine, EngineError
from ground_tools.campaign.flight import fly_point
from ground_tools.campaign.points import FlightPoint, campaign_points
from ground_tools.campaign.report import write_report
from ground_tools.campaign.spec import CampaignError, CampaignSpec, flight_count, load_campaign
from ground_tools.campaign.store import ResultStore, StoreError, open_store
from transport.cli import fail, writable_folder

PROG = "vtol campaign"
INTERRUPTED = 130  # the shell's status for a command stopped by SIGINT


def _bar(total: int, done: int, disable: bool) -> tqdm:
    return tqdm(total=total, initial=done, desc="flights", unit="flight", file=sys.stderr,
                disable=True if disable else None,
                bar_format="{desc}: {n}/{total} |{bar}| {postfix} [{elapsed}, {remaining} left]")  # fmt: skip


def fly_campaign(
    spec: CampaignSpec, out: Path, store: ResultStore, engine: DaskEngine, progress: bool
) -> tuple[int, int]:
    """Fly the points the store does not have; (flown, failed)."""
    points = campaign_points(spec)
    finished = store.finished_keys()
    todo = [point for point in points if point.key not in finished]
    print(f"{PROG}: {spec.name}: {len(points)} flights, {len(points) - len(todo)} in the store, {len(todo)} to fly; "
          f"{engine.describe()}", file=sys.stderr, flush=True)  # fmt: skip
    counts = {"done": 0, "failed": 0, "lost": 0}
    bar = _bar(len(points), len(points) - len(todo), not progress)
    try:
        for point, row in engine.run(fly_point, todo, str(out.resolve()), str(spec.folder), name=_task_name):
            if isinstance(row, BaseException):
                row = _lost_task(point, row)
            store.put(spec.name, row)
            if row["status"] == "done":
                counts["done"] += 1
                counts["lost"] += row["metrics"].get("survived") is False
            else:
                counts["failed"] += 1
                tqdm.write(f"{PROG}: flight {point.key} ({point.controller}, {point.params}) failed: "
                           f"{str(row['error']).strip().splitlines()[-1]}", file=sys.stderr)  # fmt: skip
            bar.set_postfix_str(f"done {counts['done']}, failed {counts['failed']}, aircraft lost {counts['lost']}")
            bar.update(1)
            if not progress:
                stored = len(points) - len(todo) + counts["done"] + counts["failed"]
                print(f"{PROG}: stored {stored}/{len(points)}: {_describe(point, row)}", file=sys.stderr, flush=True)
    finally:
        bar.close()
    return counts["done"] + counts["failed"], counts["failed"]


def _describe(point: FlightPoint, row: dict) -> str:
    params = ", ".join(f"{key} {value:g}" if isinstance(value, float) else f"{key} {value}"
                       for key, value in point.params.items())  # fmt: skip
    if row["status"] != "done":
        outcome = "failed to fly"
    else:
        outcome = "survived" if row["metrics"].get("survived") else "aircraft lost"
    return f"{point.key} {point.controller} ({params}): {outcome}"


def _task_name(point: FlightPoint) -> str:
    return f"flight-{point.key}"


def _lost_task(point: FlightPoint, exc: BaseException) -> dict:
    return {"key": point.key, "scenario": point.scenario, "controller": point.controller,
            "repetition": point.repetition, "params": point.params, "status": "failed",
            "error": f"the engine lost the task: {exc!r}", "metrics": {}}  # fmt: skip


def campaign(args: argparse.Namespace) -> int:
    try:
        spec = load_campaign(Path(args.file))
    except CampaignError as exc:
        fail(PROG, str(exc))
    out = writable_folder(PROG, Path(args.out) if args.out else Path("runs") / "campaigns" / spec.name)
    try:
        store = open_store(out, read_only=args.report)
    except StoreError as exc:
        fail(PROG, str(exc))
    failed = 0
    try:
        if not args.report:
            started = time.perf_counter()
            try:
                with DaskEngine(args.address, args.workers or os.cpu_count() or 1) as engine:
                    flown, failed = fly_campaign(spec, out, store, engine, not args.no_progress)
            except EngineError as exc:
                fail(PROG, str(exc))
            except KeyboardInterrupt:
                print(f"{PROG}: interrupted; {len(store.finished_keys())} flight(s) in the store: run the same command "
                      "again to fly the rest", file=sys.stderr)  # fmt: skip
                return INTERRUPTED
            minutes = (time.perf_counter() - started) / 60.0
            rate = f", {flown / minutes:.1f} flights/min" if flown and minutes > 0 else ""
            print(f"{PROG}: {flown} flight(s) flown in {minutes:.1f} min{rate}; {failed} failed", file=sys.stderr)
        report = write_report(spec, store.frame(), out)
    finally:
        store.close()
    print(f"{PROG}: store {out / 'campaign.duckdb'}; report {report} ({flight_count(spec)} flights planned)")
    return 1 if failed else 0
