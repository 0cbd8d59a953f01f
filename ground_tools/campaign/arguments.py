"""`vtol campaign`'s command line, apart from the command (ground_tools/campaign/command.py), so that the other
`vtol` commands build their parser without importing Dask, DuckDB and pandas."""

from __future__ import annotations

import argparse

from ground_tools.exit_status import epilog
from transport.cli import bounded_int

EPILOG = epilog(
    ok="every flight flown (or, with --report, the report written)",
    failed="some flight failed to fly (its reason in the store and the report)",
)
EPILOG += (
    " A status of 2 also says the campaign extra is not installed (pip install 'tiltrotor-sitl[campaign]')."
    " The campaign file is checked whole (its report table too) before anything flies."
)


def add_campaign_arguments(parser: argparse.ArgumentParser) -> None:
    parser.epilog = EPILOG
    parser.add_argument("file", metavar="FILE", help="the campaign (TOML, docs/campaigns.md)")
    parser.add_argument(
        "--out", metavar="DIR", help="campaign folder: store, flights, report (default ./runs/campaigns/NAME)"
    )
    where = parser.add_mutually_exclusive_group()
    where.add_argument(
        "--workers",
        type=bounded_int(1, 512),
        metavar="N",
        help="local cluster of N worker processes (default: one per core)",
    )
    where.add_argument(
        "--address",
        metavar="ADDR",
        help="fly on the Dask cluster whose scheduler is at ADDR (e.g. tcp://10.0.0.5:8786) instead of a local one",
    )
    parser.add_argument("--report", action="store_true", help="only write the report from the store")
    parser.add_argument("--no-progress", action="store_true", help="no progress bar")
