"""What runs a campaign's runs: a pool of processes on this machine, or Ray.

Both hand out the same rows (:func:`scale.runs.run_one`, the closed-loop ``sim`` of one spec);
they differ in what they cost to start and where they can run.

- ``pool``: ``--cpus`` worker processes on this machine (:class:`PoolRunner`). On Linux they
  are forked from this process, so they start in milliseconds with the project already
  imported; elsewhere they are spawned (each imports the project once). Nothing to install
  beyond the project, nothing to shut down.
- ``ray``: Ray tasks (:class:`RayRunner`), on a local Ray started for the campaign or on a
  cluster by ``--address``. A local Ray costs about 4 s of start, worker imports and stop on
  a 2-core machine (issue 42 measured it); a cluster is what it is for.

``auto`` (the default) is ``ray`` with an ``--address`` and ``pool`` without.
"""

from __future__ import annotations

import multiprocessing
import os
import platform
import sys
from collections.abc import Iterator
from concurrent.futures import FIRST_COMPLETED, Future, ProcessPoolExecutor, wait
from contextlib import contextmanager
from typing import Any, Protocol

from orchestrator.config import AppConfig
from scale.engine import EngineError, EngineInfo, normalise_address, ray_session
from scale.runs import RunSpec, make_row, run_one

ENGINES = ("auto", "pool", "ray")


class Runner(Protocol):
    """Runs specs and hands back their rows as they finish."""

    info: EngineInfo

    def submit(self, config: AppConfig, specs: list[RunSpec]) -> dict[Any, RunSpec]:
        """Start every spec; a handle per spec."""

    def finished(self, handles: list[Any]) -> list[Any]:
        """Wait until at least one of ``handles`` is done; the done ones."""

    def row(self, handle: Any, spec: RunSpec) -> dict[str, Any]:
        """A done run's row (with its ``summary``); a run the engine lost is a failed row."""

    def cancel(self, handles: list[Any]) -> None:
        """Stop the runs not yet done (an interrupted campaign)."""


def failed_row(spec: RunSpec, exc: BaseException) -> dict[str, Any]:
    """The row of a run the engine could not run (a worker died, a node was lost)."""
    text = str(exc).strip().splitlines()
    row = make_row(spec, None, 0.0, f"{type(exc).__name__}: {text[-1] if text else ''}")
    row["summary"] = None
    return row


def resolve_engine(engine: str, address: str | None) -> str:
    """``pool`` or ``ray`` for ``--engine`` and ``--address``; :class:`EngineError` when they
    disagree (a pool runs on this machine only)."""
    if engine not in ENGINES:
        raise EngineError(f"--engine {engine!r}: one of {', '.join(ENGINES)}")
    remote = normalise_address(address) is not None
    if engine == "auto":
        return "ray" if remote else "pool"
    if engine == "pool" and remote:
        raise EngineError("--engine pool runs on this machine: drop --address, or use "
                          "--engine ray")
    return engine


class PoolRunner:
    """``processes`` worker processes on this machine (forked on Linux)."""

    def __init__(self, processes: int) -> None:
        method = "fork" if sys.platform.startswith("linux") else "spawn"
        self._pool = ProcessPoolExecutor(max_workers=processes,
                                         mp_context=multiprocessing.get_context(method))
        self.info = EngineInfo("pool", platform.python_version(), "local", 1, float(processes))

    def submit(self, config: AppConfig, specs: list[RunSpec]) -> dict[Any, RunSpec]:
        return {self._pool.submit(run_one, config, spec): spec for spec in specs}

    def finished(self, handles: list[Any]) -> list[Any]:
        done, _ = wait(handles, return_when=FIRST_COMPLETED)
        return list(done)

    def row(self, handle: Any, spec: RunSpec) -> dict[str, Any]:
        future: Future[dict[str, Any]] = handle
        exc = future.exception()
        return failed_row(spec, exc) if exc is not None else future.result()

    def cancel(self, handles: list[Any]) -> None:
        for future in handles:
            future.cancel()

    def close(self) -> None:
        # the runs not cancelled (already running) end on their own: a run is short
        self._pool.shutdown(wait=True, cancel_futures=True)


class RayRunner:
    """Ray tasks of one CPU each, in a :func:`scale.engine.ray_session`."""

    def __init__(self, info: EngineInfo) -> None:
        import ray

        self._ray = ray
        self._task = ray.remote(num_cpus=1, max_retries=0)(run_one)
        self._config: tuple[AppConfig, Any] | None = None
        """The configuration last put in the object store, and its reference."""
        self.info = info

    def submit(self, config: AppConfig, specs: list[RunSpec]) -> dict[Any, RunSpec]:
        if self._config is None or self._config[0] is not config:  # tune submits per trial
            self._config = (config, self._ray.put(config))
        return {self._task.remote(self._config[1], spec): spec for spec in specs}

    def finished(self, handles: list[Any]) -> list[Any]:
        ready, _ = self._ray.wait(handles, num_returns=1)
        return list(ready)

    def row(self, handle: Any, spec: RunSpec) -> dict[str, Any]:
        try:
            row: dict[str, Any] = self._ray.get(handle)
            return row
        except Exception as exc:  # the engine's failure is this run's failure, not the campaign's
            return failed_row(spec, exc)

    def cancel(self, handles: list[Any]) -> None:
        for ref in handles:
            self._ray.cancel(ref, force=True)


@contextmanager
def runner_session(engine: str, address: str | None = None, num_cpus: int | None = None
                   ) -> Iterator[Runner]:
    """The runner ``engine`` names (see :func:`resolve_engine`), closed after."""
    if resolve_engine(engine, address) == "pool":
        pool = PoolRunner(num_cpus or os.cpu_count() or 1)
        try:
            yield pool
        finally:
            pool.close()
        return
    with ray_session(address, num_cpus) as info:
        yield RayRunner(info)
