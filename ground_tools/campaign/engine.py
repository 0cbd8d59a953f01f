"""The distributed engine under a campaign: Dask (docs/design/alternatives.md says why Dask, with the measurement). A local
cluster of worker processes on 127.0.0.1, started and stopped here, or an existing cluster's scheduler given by
its address. One flight per worker thread at a time; results come back as they finish.

Nothing outlives the command: a local cluster's workers end at once when the command's process ends, however it
ends (Dask's nanny holds a pipe to each worker, which exits when the pipe closes), and a flight's plant and
autopilot are killed by the kernel when their worker ends (ground_tools/scenario_run.py)."""

from __future__ import annotations

import logging
from collections.abc import Callable, Iterator, Sequence
from typing import Any

from dask.distributed import Client, LocalCluster, as_completed

from transport.ports import LOOPBACK


class EngineError(RuntimeError):
    """The cluster could not be started or reached."""


class DaskEngine:
    """`with DaskEngine(address, workers) as engine: for point, result in engine.run(fn, points, *args): ...`"""

    def __init__(self, address: str | None, workers: int) -> None:
        self.address = address
        self.workers = workers
        self.cluster: LocalCluster | None = None
        self.client: Client | None = None

    def __enter__(self) -> DaskEngine:
        try:
            if self.address is None:
                self.cluster = LocalCluster(n_workers=self.workers, threads_per_worker=1, processes=True, host=LOOPBACK,
                                            dashboard_address=None, silence_logs=logging.ERROR)  # fmt: skip
                self.client = Client(self.cluster)
            else:
                self.client = Client(self.address, timeout=30)
        except (OSError, TimeoutError, ValueError) as exc:  # ValueError: an address Dask cannot read
            self.__exit__(None, None, None)
            where = "a local cluster" if self.address is None else f"the cluster at {self.address}"
            raise EngineError(f"cannot start or reach {where}: {exc}") from None
        return self

    def __exit__(self, *exc: object) -> None:
        if self.client is not None:
            self.client.close()
        if self.cluster is not None:
            self.cluster.close()

    def describe(self) -> str:
        assert self.client is not None
        threads = sum(self.client.nthreads().values())
        where = f"local cluster on {LOOPBACK}" if self.address is None else f"cluster {self.address}"
        return f"{where}: {len(self.client.nthreads())} worker(s), {threads} flight(s) at a time"

    def run(
        self, fn: Callable[..., Any], items: Sequence[Any], *args: Any, name: Callable[[Any], str]
    ) -> Iterator[tuple[Any, Any | BaseException]]:
        """(item, fn(item, *args)) as each finishes, or (item, the exception) when the task itself failed (a
        worker lost too often)."""
        assert self.client is not None
        futures = {self.client.submit(fn, item, *args, key=name(item), pure=False): item for item in items}
        try:
            for future in as_completed(futures):
                try:
                    yield futures[future], future.result()
                except Exception as exc:  # the row records it: the campaign goes on with the other flights
                    yield futures[future], exc
        finally:
            self.client.cancel(list(futures))
