"""The parsers ``bench fuzz`` drives: each takes one input the way the stack takes it.

A target keeps one parser for :data:`FRESH_EVERY` inputs (state carries over, as on a live
link that keeps delivering garbage) and then starts a fresh one. ``feed(data)`` must not raise:
whatever escapes it is an uncaught exception (a crash of the receiver thread on the car). The
only exceptions a target lets through as a *clear error* are those in ``clear_errors`` (a file
that is not a recording raises :class:`RecordingError` with one line saying so, by design);
the harness counts those separately. ``rejected()`` says how many inputs the parsers counted
as rejections so far.
"""

from __future__ import annotations

import tempfile
from collections import Counter
from pathlib import Path
from typing import Any

from bench.fuzz_corpus import bytes_frame
from common.errors import RecordingError

FRESH_EVERY = 500
"""Inputs fed to one parser instance before a new one is made."""


class Target:
    """One parser under fuzzing (see the module docstring)."""

    name = ""
    clear_errors: tuple[type[BaseException], ...] = ()
    ordered = False
    """Mutate the seed inputs in their order (a stream), not picked at random."""
    in_place_share = 0.0
    """Share of inputs whose mutations keep the length (see :class:`Mutator`)."""

    def __init__(self) -> None:
        self.fed = 0
        self.t_s = 0.0
        self._rejects: Counter[str] = Counter()
        self._parser: Any = None

    def feed(self, data: bytes) -> None:
        """Run one input through the parser."""
        if self._parser is None or self.fed % FRESH_EVERY == 0:
            self._retire()
            self._parser = self.make()
        self.fed += 1
        self.run(data)

    def rejected(self) -> int:
        """Rejections counted by the parsers (all instances so far)."""
        return sum(self._rejects.values()) + sum(self._counter().values())

    def close(self) -> None:
        """Flush the last parser (its end-of-stream path runs too)."""
        self._retire()

    def _retire(self) -> None:
        if self._parser is not None:
            self.finish()
            self._rejects.update(self._counter())
            self._parser = None

    def _counter(self) -> Counter[str]:
        rejects = getattr(self._parser, "rejects", None)
        return rejects if isinstance(rejects, Counter) else Counter()

    # -- per parser ---------------------------------------------------------------------------

    def make(self) -> Any:
        raise NotImplementedError

    def run(self, data: bytes) -> None:
        raise NotImplementedError

    def finish(self) -> None:
        """End of a parser's stream (flush)."""


class NmeaTarget(Target):
    """GPS serial bytes: :class:`sensors.nmea.NmeaParser`, 9600 baud arrival times."""

    name = "nmea"

    def make(self) -> Any:
        from sensors.nmea import NmeaParser

        return NmeaParser()

    def run(self, data: bytes) -> None:
        self.t_s += len(data) * 10.0 / 9600.0
        self._parser.feed(self.t_s, data)

    def finish(self) -> None:
        self._parser.flush()


class ImuTarget(Target):
    """IMU serial bytes: :class:`sensors.imu_protocol.ImuParser` with sensor time."""

    name = "imu"

    def make(self) -> Any:
        from sensors.imu_protocol import ImuParser

        return ImuParser()

    def run(self, data: bytes) -> None:
        self.t_s += 0.005
        self._parser.feed(self.t_s, data)

    def finish(self) -> None:
        self._parser.flush()


class CanTarget(Target):
    """CAN frames through our car's DBC (readings and the actuator command) and the RAV4's."""

    name = "can"

    def __init__(self, data_dir: Path) -> None:
        super().__init__()
        self._dbc = next(iter(sorted((data_dir / "can").glob("*.dbc"))), None)

    def make(self) -> Any:
        from sensors.can_codec import CanCodec

        return (CanCodec(), CanCodec(self._dbc) if self._dbc is not None else None)

    def run(self, data: bytes) -> None:
        self.t_s += 0.001
        frame = bytes_frame(data, self.t_s)
        ours, other = self._parser
        ours.decode(frame)
        ours.decode_command(frame)
        if other is not None:
            other.decode_signals(frame, decode_choices=True)

    def _counter(self) -> Counter[str]:
        if self._parser is None:
            return Counter()
        return sum((c.rejects for c in self._parser if c is not None), Counter())


class LidarTarget(Target):
    """LiDAR datagrams: :class:`sensors.lidar_parser.LidarParser` (model check, sweeps,
    cone detection) for ``lidar.model`` ``model`` (an Ouster with its metadata file
    ``meta_file``), one datagram per input, 1.327 ms apart."""

    ordered = True
    in_place_share = 0.7

    def __init__(self, name: str = "lidar", model: str = "vlp16", meta_file: str = "") -> None:
        super().__init__()
        self.name = name
        self._model = model
        self._meta_file = meta_file

    def make(self) -> Any:
        from sensors.config import LidarConfig
        from sensors.lidar_parser import LidarParser

        return LidarParser(LidarConfig(model=self._model, meta_file=self._meta_file))

    def run(self, data: bytes) -> None:
        self.t_s += 0.001327
        self._parser.feed(self.t_s, data)

    def finish(self) -> None:
        self._parser.flush()


class CameraTarget(Target):
    """Camera datagrams: :class:`sensors.camera_codec.CameraParser`."""

    name = "camera"

    def make(self) -> Any:
        from sensors.camera_codec import CameraParser

        return CameraParser()

    def run(self, data: bytes) -> None:
        self.t_s += 0.033
        self._parser.feed(self.t_s, data)


class McapTarget(Target):
    """Recording files: ``info`` and the :class:`recordings.player.Player` of ``replay`` on a
    (mutated) file; a file that cannot be read at all raises a one-line RecordingError."""

    name = "mcap"
    clear_errors = (RecordingError,)

    def __init__(self) -> None:
        super().__init__()
        base = Path("/dev/shm") if Path("/dev/shm").is_dir() else None
        self._dir = tempfile.TemporaryDirectory(prefix="fsd-fuzz-", dir=base)
        self._path = Path(self._dir.name) / "input.mcap"
        self.decode_errors = 0

    def make(self) -> Any:
        return object()

    def run(self, data: bytes) -> None:
        from recordings.info import info
        from recordings.player import Player

        self._path.write_bytes(data)
        info(self._path)
        player = Player(self._path)
        for _ in player:
            pass
        self.decode_errors += player.decode_errors

    def rejected(self) -> int:
        return self.decode_errors

    def close(self) -> None:
        super().close()
        self._dir.cleanup()


def make_targets(data_dir: Path) -> dict[str, Target]:
    """Every target by name."""
    return {
        "nmea": NmeaTarget(),
        "imu": ImuTarget(),
        "can": CanTarget(data_dir),
        "lidar": LidarTarget(),
        "lidar-hdl32e": LidarTarget("lidar-hdl32e", "hdl32e"),
        "lidar-os1": LidarTarget("lidar-os1", "os1-64",
                                 str(data_dir / "lidar" / "ouster_example.json")),
        "camera": CameraTarget(),
        "mcap": McapTarget(),
    }
