"""The engine campaigns and tuning run on: Ray, local on this machine or a cluster by address.

:func:`require_ray` imports Ray or stops with one line saying how to install it;
:func:`ray_session` starts a local Ray (``num_cpus`` workers, no dashboard) or connects to a
cluster (``ray://HOST:PORT`` through the Ray client, ``HOST:PORT`` as a driver on a node of that
cluster), with Ray's own startup logging kept out of the output, and shuts it down after.

Workers import this project from :data:`PROJECT_ROOT` (put first on their ``PYTHONPATH``), so a
cluster's nodes must have the project at that path (this machine, or the same checkout on
every node). Their BLAS libraries run one thread each, as in ``main.py``: the same arithmetic,
hence the same ``outputs_sha256``, as a run on its own.
"""

from __future__ import annotations

import logging
import os
import warnings
from collections.abc import Iterator
from contextlib import contextmanager
from dataclasses import dataclass
from pathlib import Path
from types import ModuleType
from typing import Any

from common.errors import FsdError

log = logging.getLogger(__name__)

PROJECT_ROOT = Path(__file__).resolve().parents[1]
"""The folder holding ``main.py`` and the packages (what workers import)."""

OBJECT_STORE_BYTES = 200 * 1024 * 1024
"""Object store of a local Ray (bytes): a run's row and summary are a few kB, the configuration
a few more; Ray's default (30 % of the memory) would take a shared machine's memory."""

INSTALL_HINT = 'pip install -e ".[scale]"'


class EngineError(FsdError):
    """Ray is missing, or the cluster cannot be reached."""


def require_ray() -> ModuleType:
    """The ``ray`` module, or :class:`EngineError` with one line saying how to install it."""
    try:
        import ray
    except ImportError:
        raise EngineError(f"campaigns and tuning run on Ray, which is not installed: "
                          f"{INSTALL_HINT}") from None
    return ray


def require_optuna() -> ModuleType:
    """The ``optuna`` module, or :class:`EngineError` with one line saying how to install it."""
    try:
        import optuna
    except ImportError:
        raise EngineError(f"tuning uses Optuna, which is not installed: {INSTALL_HINT}"
                          ) from None
    return optuna


def worker_env() -> dict[str, str]:
    """Environment of the workers: this project first on the path, one BLAS thread."""
    path = [str(PROJECT_ROOT)]
    if os.environ.get("PYTHONPATH"):
        path.append(os.environ["PYTHONPATH"])
    env = {"PYTHONPATH": os.pathsep.join(path)}
    for name in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
        env[name] = "1"
    return env


@dataclass
class EngineInfo:
    """What ran the campaign (for ``campaign.json``)."""

    engine: str
    version: str
    address: str
    """``local`` or the address given."""
    nodes: int
    cpus: float

    def as_dict(self) -> dict[str, Any]:
        return {"engine": self.engine, "version": self.version, "address": self.address,
                "nodes": self.nodes, "cpus": self.cpus}


def normalise_address(address: str | None) -> str | None:
    """``None`` (local), ``ray://HOST:PORT`` (client) or ``HOST:PORT`` (a cluster's GCS);
    :class:`EngineError` for anything else."""
    if address is None or address in ("", "local"):
        return None
    rest = address.removeprefix("ray://")
    host, colon, port = rest.rpartition(":")
    if not colon or not host or not port.isdigit():
        raise EngineError(f"--address {address!r}: expected ray://HOST:PORT or HOST:PORT")
    return address


@contextmanager
def _environment(values: dict[str, str]) -> Iterator[None]:
    """This process's environment with ``values`` set, restored after."""
    before = {name: os.environ.get(name) for name in values}
    os.environ.update(values)
    try:
        yield
    finally:
        for name, value in before.items():
            if value is None:
                os.environ.pop(name, None)
            else:
                os.environ[name] = value


@contextmanager
def ray_session(address: str | None = None, num_cpus: int | None = None) -> Iterator[EngineInfo]:
    """Ray started locally (``num_cpus`` CPUs, default all) or joined at ``address``; yields what
    it is, and shuts it down (a local Ray) or disconnects (a cluster) after."""
    ray = require_ray()
    address = normalise_address(address)
    runtime_env = {"env_vars": worker_env()}  # a cluster's workers: set by Ray
    quiet = {"logging_level": logging.ERROR, "log_to_driver": False,
             "configure_logging": True}
    os.environ.setdefault("RAY_ACCEL_ENV_VAR_OVERRIDE_ON_ZERO", "0")
    # Ray nices its workers (15) by default; here they are the work itself, and niced they
    # starve beside any busy process (a campaign test took minutes on a loaded machine)
    os.environ.setdefault("RAY_worker_niceness", "0")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        try:
            if address is None:
                # "local": a new Ray of our own, never one some other program started here.
                # Its workers inherit the environment Ray starts with: given the worker
                # environment that way rather than as a runtime_env, the workers Ray starts
                # with it serve the first tasks (a runtime_env has new ones started for it,
                # about 1.6 s more before the first run here).
                with _environment(worker_env()):
                    ray.init(address="local", num_cpus=num_cpus or os.cpu_count() or 1,
                             include_dashboard=False, object_store_memory=OBJECT_STORE_BYTES,
                             **quiet)
            else:
                ray.init(address=address, runtime_env=runtime_env, **quiet)
        except (ConnectionError, RuntimeError, TimeoutError, ValueError) as exc:
            first = str(exc).strip().splitlines()[0] if str(exc).strip() else type(exc).__name__
            raise EngineError(f"cannot start or reach Ray at {address or 'local'}: {first}"
                              ) from None
    # Ray's loggers are set up by init; what they say at startup is not the campaign's output.
    for name in ("ray", "ray.worker", "ray._private"):
        logging.getLogger(name).setLevel(logging.ERROR)
    try:
        nodes = [n for n in ray.nodes() if n.get("Alive")]
        info = EngineInfo("ray", ray.__version__, address or "local", len(nodes),
                          float(ray.cluster_resources().get("CPU", 0.0)))
        log.info("ray %s at %s: %d node(s), %g CPUs", info.version, info.address, info.nodes,
                 info.cpus)
        yield info
    finally:
        ray.shutdown()
