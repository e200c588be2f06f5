"""Replay's front end: the recording read and parsed by the Sensor Manager, tick by tick.

The front end is what stands in for the car's sensors in a replay: it reads the recording in
log-time order (paced by ``--rate``), hands each control tick's raw units to a
:class:`~sensors.manager.SensorManager` and yields, per tick, the parsed readings and the
sensors' health at that tick (:class:`TickInput`). It depends on nothing the rest of the stack
computes, so it can run in a process of its own (:func:`tick_inputs_in_process`), a tick batch
ahead of Main, the way the car's receivers run beside its loop. The ticks it yields are the
same either way, so the replay's outputs are too.
"""

from __future__ import annotations

import copyreg
import dataclasses
import enum
import functools
import io
import logging
import multiprocessing
import multiprocessing.connection
import pickle
import time
from collections.abc import Callable, Iterator
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from common import messages
from common.clock import SimClock
from common.errors import RecordingError
from common.messages import CanFrame, GroundTruth, Health, RawBytes, Reading
from common.track import TrackLayout
from orchestrator.config import AppConfig
from orchestrator.managers import make_sensors
from recordings.player import Player
from recordings.topics import RAW_TOPICS, TRUTH_POSE, TRUTH_TRACK
from sensors.manager import SensorBatch

log = logging.getLogger(__name__)

TICKS_PER_BATCH = 20
"""Ticks sent from the front-end process to Main at once (0.2 s of recording at 100 Hz)."""
PIPE_BYTES = 1 << 20
"""Capacity asked for the pipe from the front end to Main (bytes)."""


@dataclass(slots=True)
class TickInput:
    """What the sensors hand Main for one tick at ``t_s`` (s, recording clock).

    ``readings``: parsed readings in time order; ``health``: the sensors' health at ``t_s``;
    ``truth``: ground-truth poses recorded in the tick, as (log time s, message); ``track``:
    the recorded track when it arrived in this tick (simulation recordings only).
    """

    t_s: float
    readings: list[Reading]
    health: Health
    truth: list[tuple[float, GroundTruth]] = field(default_factory=list)
    track: Any = None


@dataclass(slots=True)
class FrontEndTimes:
    """Wall time (s) of the front end: reading and decoding the recording, and the sensors."""

    read_s: float = 0.0
    sensors_s: float = 0.0
    ticks: int = 0


def tick_inputs(config: AppConfig, path: Path, rate: float | None, n_ticks: int,
                times: FrontEndTimes | None = None) -> Iterator[TickInput]:
    """Ticks 1..``n_ticks`` of a replay of ``path`` (tick k at k / control_rate_hz).

    Each tick is handed the raw units whose log time falls in it, so what a tick contains does
    not depend on the rate (which only paces the reading).
    """
    times = times if times is not None else FrontEndTimes()
    dt_s = 1.0 / config.run.control_rate_hz
    clock = SimClock()
    sensors = make_sensors(config, clock, keep_raw=False)  # a replay records nothing
    stream = iter(Player(path, rate=rate, topics=[*RAW_TOPICS, TRUTH_POSE, TRUTH_TRACK]))
    clock_now = time.perf_counter
    t_read = clock_now()
    pending: tuple[float, str, Any] | None = next(stream, None)
    for k in range(1, n_ticks + 1):
        t_s = k * dt_s
        raw: list[RawBytes | CanFrame] = []
        truth: list[tuple[float, GroundTruth]] = []
        track = None
        while pending is not None and pending[0] <= t_s + 1e-9:
            log_time_s, topic, message = pending
            if isinstance(message, (RawBytes, CanFrame)):
                raw.append(message)
            elif isinstance(message, GroundTruth):
                truth.append((log_time_s, message))
            elif topic == TRUTH_TRACK:
                track = message
            pending = next(stream, None)
        t_sensors = clock_now()
        times.read_s += t_sensors - t_read
        clock.set(t_s)
        if raw:
            sensors.ingest(raw)
        batch: SensorBatch = sensors.take()
        health = sensors.health(t_s)
        t_read = clock_now()
        times.sensors_s += t_read - t_sensors
        times.ticks += 1
        yield TickInput(t_s, batch.readings, health, truth, track)


def tick_inputs_in_process(config: AppConfig, path: Path, rate: float | None, n_ticks: int,
                           times: FrontEndTimes | None = None) -> Iterator[TickInput]:
    """:func:`tick_inputs` computed in a forked process, :data:`TICKS_PER_BATCH` ticks at a
    time, while the caller runs Main on the ticks before.

    Falls back to the caller's own process where ``fork`` is not available. An error in the
    front end is raised here as a :class:`RecordingError`; closing the iterator early stops
    the process.
    """
    if "fork" not in multiprocessing.get_all_start_methods():
        yield from tick_inputs(config, path, rate, n_ticks, times)
        return
    ctx = multiprocessing.get_context("fork")
    receive, send = ctx.Pipe(duplex=False)
    _widen_pipe(send)
    process = ctx.Process(target=_front_end_main, args=(send, config, path, rate, n_ticks),
                          name="replay-front-end", daemon=True)
    process.start()
    send.close()
    try:
        while True:
            try:
                kind, payload = load_tick_message(receive.recv_bytes())
            except EOFError:
                raise RecordingError(
                    f"{path}: the replay's front-end process ended without a word "
                    f"(exit code {process.exitcode})") from None
            if kind == "ticks":
                yield from payload
            elif kind == "done":
                if times is not None:
                    done: FrontEndTimes = payload
                    times.read_s, times.sensors_s, times.ticks = (
                        done.read_s, done.sensors_s, done.ticks)
                return
            else:
                raise RecordingError(f"{path}: replay front end failed: {payload}")
    finally:
        receive.close()
        process.join(timeout=1.0)
        if process.is_alive():
            process.terminate()
            process.join(timeout=1.0)


def _widen_pipe(conn: multiprocessing.connection.Connection) -> None:
    """Let the pipe hold up to 1 MiB (Linux; default 64 KiB, about 80 ticks): the front end can
    then run over a second of recording ahead, so neither side waits on the other's slow ticks
    (a sweep with many cones, a replan)."""
    try:
        import fcntl

        fcntl.fcntl(conn.fileno(), fcntl.F_SETPIPE_SZ, PIPE_BYTES)
    except (ImportError, AttributeError, OSError) as exc:  # not Linux, or over the maximum
        log.debug("pipe size left at the default: %s", exc)


def _keep_freed_memory() -> None:
    """glibc only: keep freed blocks of up to 32 MiB in the heap for reuse instead of giving
    them back to the kernel. Every LiDAR sweep allocates arrays of about 0.5 MiB (decoded
    points, detector temporaries); fresh pages cost a page fault each, about 0.3 ms a sweep."""
    try:
        import ctypes
        import ctypes.util

        libc = ctypes.CDLL(ctypes.util.find_library("c") or "libc.so.6")
        mallopt = libc.mallopt
    except (OSError, AttributeError):
        return
    m_trim_threshold, m_mmap_threshold = -1, -3
    mallopt(m_mmap_threshold, 32 << 20)
    mallopt(m_trim_threshold, 64 << 20)


def _front_end_main(send: multiprocessing.connection.Connection, config: AppConfig,
                    path: Path, rate: float | None, n_ticks: int) -> None:
    """The front-end process: batches of :class:`TickInput`, then ``done`` with the times
    (or ``error`` with a one-line reason)."""
    _keep_freed_memory()
    times = FrontEndTimes()
    batch: list[TickInput] = []
    dumps = _message_pickler()
    try:
        for tick in tick_inputs(config, path, rate, n_ticks, times):
            batch.append(tick)
            if len(batch) >= TICKS_PER_BATCH:
                send.send_bytes(dumps(("ticks", batch)))
                batch = []
        if batch:
            send.send_bytes(dumps(("ticks", batch)))
        send.send_bytes(dumps(("done", times)))
    except (BrokenPipeError, KeyboardInterrupt):
        pass  # Main stopped reading: nothing to report to
    except Exception as exc:  # noqa: BLE001 (reported to Main, which raises it)
        log.exception("replay front end failed")
        try:
            send.send_bytes(dumps(("error", f"{type(exc).__name__}: {exc}")))
        except OSError:
            pass
    finally:
        send.close()


def _message_pickler() -> Callable[[object], bytes]:
    """``pickle.dumps`` that stores the message dataclasses as their class and field values
    (rebuilt by calling the class), which unpickles about twice as fast as the default state
    dictionaries of slotted dataclasses. Only ever read back by our own Main process."""
    table = copyreg.dispatch_table.copy()
    for cls in [*vars(messages).values(), TrackLayout, TickInput, FrontEndTimes]:
        if isinstance(cls, type) and dataclasses.is_dataclass(cls):
            names = tuple(f.name for f in dataclasses.fields(cls) if f.init)
            table[cls] = functools.partial(_reduce_dataclass, cls, names)

    def dumps(obj: object) -> bytes:
        buffer = io.BytesIO()
        pickler = pickle.Pickler(buffer, protocol=pickle.HIGHEST_PROTOCOL)
        pickler.dispatch_table = table
        pickler.dump(obj)
        return buffer.getvalue()

    return dumps


def _reduce_dataclass(cls: type, names: tuple[str, ...], obj: object
                      ) -> tuple[type, tuple[Any, ...]]:
    return cls, tuple([getattr(obj, name) for name in names])


_ALLOWED_GLOBALS = {
    "orchestrator.replay_front": {"TickInput", "FrontEndTimes"},
    "common.track": {"TrackLayout"},
    "numpy": {"dtype", "ndarray"},
    "numpy._core.numeric": {"_frombuffer"},
    "numpy.core.numeric": {"_frombuffer"},
    "numpy._core.multiarray": {"_reconstruct", "scalar"},
    "numpy.core.multiarray": {"_reconstruct", "scalar"},
}


class _TickUnpickler(pickle.Unpickler):
    """Unpickles only what the front end sends: the message dataclasses and enums, the tick
    types, numpy arrays. Any other global (a function, a module) is refused, so even a
    tampered stream cannot run code (the recording itself is read as protobuf only)."""

    def find_class(self, module: str, name: str) -> Any:
        if module == "common.messages":
            obj = getattr(messages, name, None)
            if isinstance(obj, type) and (dataclasses.is_dataclass(obj)
                                          or issubclass(obj, enum.Enum)):
                return obj
        elif name in _ALLOWED_GLOBALS.get(module, ()):
            return super().find_class(module, name)
        raise pickle.UnpicklingError(f"replay front end: refusing to load {module}.{name}")


def load_tick_message(data: bytes) -> tuple[str, Any]:
    """A message of the front end, ``(kind, payload)``; see :class:`_TickUnpickler`."""
    result: tuple[str, Any] = _TickUnpickler(io.BytesIO(data)).load()
    return result
