"""The fault campaign at full size (docs/faults.md): the accel profile over a faulty plant link (5 % loss, 0-5 ms
jitter) against a clean run, and 100 000 malformed datagrams per port (plant, GCS, API) while hovering. Prints a
table: what was injected, what the vehicle did, the counters, the altitude deviation, whether the files are intact.

    python benchmarks/bench_faults.py [--per-port 100000] [--flight-s 10] [--seed 1]
"""

from __future__ import annotations

import argparse
import tempfile
import time
from pathlib import Path

from ground_tools.fault_campaign import fly_plant_link, junk_while_hovering
from tiltrotor_sitl.fault_proxy import DOWNSTREAM, UPSTREAM, Faults


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--per-port", type=int, default=100_000)
    parser.add_argument("--flight-s", type=float, default=10.0)
    parser.add_argument("--seed", type=int, default=1)
    args = parser.parse_args()
    rows: list[tuple[str, str, str, str, str]] = []
    with tempfile.TemporaryDirectory() as folder:
        work = Path(folder)
        started = time.monotonic()
        clean = fly_plant_link(work, "clean", None, duration_s=args.flight_s)
        faults = Faults(loss=0.05, jitter_s=0.005)
        faulty = fly_plant_link(work, "faulty", faults, duration_s=args.flight_s, seed=args.seed)
        proxy = faulty.proxy or {}
        up, down = proxy.get(UPSTREAM, {}), proxy.get(DOWNSTREAM, {})
        rows.append(
            (
                "plant link, clean",
                "-",
                f"accel {args.flight_s:g} s, vx RMS {clean.figures.vx_rmse:.3f} m/s",
                f"missed {clean.plant['missed_commands']}",
                f"{clean.figures.altitude_deviation:.3f}",
            )
        )
        rows.append(
            (
                f"plant link, {faults.describe()}",
                f"lost {up.get('lost')}+{down.get('lost')} of {up.get('received')}+{down.get('received')}",
                f"accel {args.flight_s:g} s, vx RMS {faulty.figures.vx_rmse:.3f} m/s, pitch max "
                f"{faulty.figures.pitch_max_deg:.1f} deg (clean {clean.figures.pitch_max_deg:.1f})",
                f"missed {faulty.plant['missed_commands']}, handshakes {faulty.plant['handshakes']}, "
                f"peer_lost {faulty.plant['peer_lost']}",
                f"{faulty.figures.altitude_deviation:.3f}",
            )
        )
        junk = junk_while_hovering(work, args.per_port, seed=args.seed)
        links = junk.autopilot.get("links", {})
        for name, injected in junk.injected.items():
            if name == "plant":
                counted = f"foreign {junk.plant['foreign']['datagrams']}, dropped {junk.plant['dropped']}"
            else:
                link = links[name]
                counted = f"received {link['received']}, dropped {link['dropped']}, ignored {link['ignored']}"
            rows.append(
                (
                    f"malformed at {name} port",
                    f"{injected.total} ({dict(injected.sent)})",
                    f"{junk.autopilot.get('flight_mode')}, armed {junk.autopilot.get('armed')}, crashed "
                    f"{junk.crashed or 'none'}",
                    counted,
                    f"{junk.figures.altitude_deviation:.3f}",
                )
            )
        elapsed = time.monotonic() - started
    print("| fault | injected | vehicle | counters | altitude dev. (m) |\n| --- | --- | --- | --- | --- |")
    for row in rows:
        print("| " + " | ".join(row) + " |")
    print(
        f"\nparameter file intact: {junk.files_intact}; set-points dropped (NaN/Inf): {links.get('setpoints_dropped')};"
        f" exit codes autopilot {junk.autopilot_rc}, plant {junk.plant_rc}; {elapsed:.0f} s wall"
    )


if __name__ == "__main__":
    main()
