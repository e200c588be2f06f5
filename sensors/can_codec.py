"""CAN frames of the car (``sensors/car.dbc``) to and from message types, through cantools.

The DBC is the single source of truth for ids, scaling and layout; this module only maps its
signals to :mod:`common.messages` types. Decoding never raises on bad input: an id the DBC does
not know (or a 29-bit id where the DBC has an 11-bit one) is counted in
``rejects["unknown_id"]`` and ignored, a frame of the wrong length in
``rejects["bad_length"]``, anything cantools refuses in ``rejects["decode_error"]``, an
actuator command with a wrong checksum in ``rejects["bad_checksum"]``. A ``MISSION_SELECT`` whose
value is no mission the stack can drive (``UNKNOWN`` or a number outside the DBC's table) is
counted in ``rejects["unknown_mission"]`` (one log line per distinct value) and read as
``Mission.UNKNOWN``, so a mission selected earlier is never kept by mistake; an ``AS_STATUS``
with a state, mission or ASSI mode outside its enum in ``rejects["bad_status"]``.
"""

from __future__ import annotations

import collections
import functools
import logging
import math
from pathlib import Path
from typing import Any

import cantools
from cantools.database.can import Database, Message

from common.errors import ConfigError
from common.messages import (
    ActuatorCommand,
    AssiMode,
    AsState,
    AsStatus,
    CanFrame,
    Mission,
    MissionSelect,
    RemoteStop,
    SteeringAngle,
    WheelSpeeds,
)

logger = logging.getLogger(__name__)

DEFAULT_DBC_PATH = Path(__file__).resolve().parent / "car.dbc"
"""The DBC file of our car, shipped with the package."""

RES_STATE_ID = 0x010
AS_COMMAND_ID = 0x050
AS_STATUS_ID = 0x051
WHEEL_SPEEDS_ID = 0x100
STEERING_ANGLE_ID = 0x101
MISSION_SELECT_ID = 0x102

CanReading = WheelSpeeds | SteeringAngle | RemoteStop | MissionSelect


def mission_from_wire(value: int) -> Mission | None:
    """The :class:`Mission` of a ``MISSION`` value on the wire; None for a number outside the
    DBC's table (never raises)."""
    try:
        return Mission(int(value))
    except ValueError:
        return None


def command_checksum(arbitration_id: int, data: bytes) -> int:
    """Toyota-style checksum of a frame whose last byte is the checksum.

    ``(id & 0xFF) + (id >> 8) + DLC + sum(data[:-1])`` modulo 256.
    """
    total = (arbitration_id & 0xFF) + ((arbitration_id >> 8) & 0xFF) + len(data) + sum(data[:-1])
    return total & 0xFF


def _clip(message: Message, values: dict[str, float]) -> dict[str, float]:
    """Saturate every value to its signal's [minimum, maximum] from the DBC."""
    out: dict[str, float] = {}
    for signal in message.signals:
        value = float(values[signal.name])
        if signal.minimum is not None:
            value = max(value, float(signal.minimum))
        if signal.maximum is not None:
            value = min(value, float(signal.maximum))
        out[signal.name] = value
    return out


@functools.lru_cache(maxsize=8)
def _load_database(path: str, mtime_ns: int) -> Database:
    """The parsed DBC file, once per file and version: a run has several codecs (one per sender)
    and parsing takes about 10 ms. The database is only read after loading, so it is shared."""
    del mtime_ns  # part of the cache key: an edited file is parsed again
    return cantools.database.load_file(path)  # type: ignore[return-value]


class CanCodec:
    """Encode and decode the car's CAN frames.

    ``dbc_path`` names a DBC file (default: the project's ``sensors/car.dbc``). The codec keeps
    the alive counters of the frames it encodes, so use one codec per sender.
    """

    source = "can"

    def __init__(self, dbc_path: str | Path | None = None) -> None:
        path = Path(dbc_path) if dbc_path else DEFAULT_DBC_PATH
        try:
            self.db: Database = _load_database(str(path.resolve()), path.stat().st_mtime_ns)
        except (OSError, cantools.database.UnsupportedDatabaseFormatError) as exc:
            raise ConfigError(f"{path}: cannot load the DBC file ({exc})") from exc
        self.dbc_path = path
        self._by_id: dict[int, Message] = {m.frame_id: m for m in self.db.messages}
        self.rejects: collections.Counter[str] = collections.Counter()
        self.counts: collections.Counter[str] = collections.Counter()
        self._counters: collections.Counter[int] = collections.Counter()
        self._unknown_missions_logged: set[int] = set()
        for name, frame_id in (
            ("RES_STATE", RES_STATE_ID),
            ("AS_COMMAND", AS_COMMAND_ID),
            ("WHEEL_SPEEDS", WHEEL_SPEEDS_ID),
            ("STEERING_ANGLE", STEERING_ANGLE_ID),
            ("AS_STATUS", AS_STATUS_ID),
            ("MISSION_SELECT", MISSION_SELECT_ID),
        ):
            message = self._by_id.get(frame_id)
            if message is not None and message.name != name:
                logger.warning("%s: id 0x%03X is %s, expected %s", path, frame_id,
                               message.name, name)

    # -- decoding -------------------------------------------------------------------------

    def decode_signals(self, frame: CanFrame, decode_choices: bool = False
                       ) -> tuple[Message, dict[str, Any]] | None:
        """The DBC message and its physical signal values, or None (rejection counted).

        ``decode_choices`` gives value-table entries by name instead of number."""
        message = self._by_id.get(frame.arbitration_id)
        if message is None or bool(message.is_extended_frame) != bool(frame.is_extended_id):
            # a 29-bit id is another frame than the 11-bit one with the same number
            self.rejects["unknown_id"] += 1
            return None
        if len(frame.data) != message.length:
            self.rejects["bad_length"] += 1
            return None
        try:
            signals = message.decode(bytes(frame.data), decode_choices=decode_choices)
        except Exception as exc:  # cantools raises several kinds; all mean "bad frame"
            self.rejects["decode_error"] += 1
            logger.debug("cannot decode 0x%03X %s: %s", frame.arbitration_id, frame.data.hex(), exc)
            return None
        return message, dict(signals)  # type: ignore[arg-type]

    def decode(self, frame: CanFrame) -> list[CanReading]:
        """Readings in one frame (``[]`` for the command frame, unknown ids and bad frames)."""
        decoded = self.decode_signals(frame)
        if decoded is None:
            return []
        message, s = decoded
        t = frame.timestamp_s
        fid = message.frame_id
        if fid == WHEEL_SPEEDS_ID:
            self.counts["wheel_speeds"] += 1
            return [WheelSpeeds(t, float(s["WHEEL_SPEED_FL"]), float(s["WHEEL_SPEED_FR"]),
                                float(s["WHEEL_SPEED_RL"]), float(s["WHEEL_SPEED_RR"]))]
        if fid == STEERING_ANGLE_ID:
            self.counts["steering"] += 1
            return [SteeringAngle(t, float(s["STEERING_ANGLE"]))]
        if fid == RES_STATE_ID:
            self.counts["res"] += 1
            return [RemoteStop(t, bool(s["RES_EMERGENCY"]), bool(s["RES_GO"]))]
        if fid == MISSION_SELECT_ID:
            self.counts["mission"] += 1
            return [self._mission(t, int(s["MISSION"]))]
        self.counts[message.name.lower()] += 1
        return []

    def _mission(self, timestamp_s: float, raw: int) -> MissionSelect:
        mission = mission_from_wire(raw)
        if mission is not None and mission != Mission.UNKNOWN:
            return MissionSelect(timestamp_s, mission, raw)
        self.rejects["unknown_mission"] += 1
        if raw not in self._unknown_missions_logged:
            self._unknown_missions_logged.add(raw)
            known = ", ".join(f"{m.value} {m.name.lower()}" for m in Mission if m.selectable)
            logger.warning("MISSION_SELECT: mission value %d is no mission the stack can drive"
                           " (known: %s); read as UNKNOWN", raw, known)
        return MissionSelect(timestamp_s, Mission.UNKNOWN, raw)

    def decode_command(self, frame: CanFrame) -> ActuatorCommand | None:
        """The actuator command in an AS_COMMAND frame; None (counted) when it is not valid."""
        if frame.arbitration_id != AS_COMMAND_ID:
            return None
        decoded = self.decode_signals(frame)
        if decoded is None:
            return None
        _, s = decoded
        if int(s["CHECKSUM"]) != command_checksum(frame.arbitration_id, frame.data):
            self.rejects["bad_checksum"] += 1
            return None
        try:
            state = AsState(int(s["AS_STATE"]))
            throttle = min(max(float(s["THROTTLE_CMD"]), 0.0), 1.0)
            brake = min(max(float(s["BRAKE_CMD"]), 0.0), 1.0)
            return ActuatorCommand(frame.timestamp_s, throttle, brake,
                                   float(s["STEERING_CMD"]), state)
        except ValueError:
            self.rejects["bad_command"] += 1
            return None

    def decode_as_status(self, frame: CanFrame) -> AsStatus | None:
        """The status in an AS_STATUS frame; None (counted) when it is not valid."""
        if frame.arbitration_id != AS_STATUS_ID:
            return None
        decoded = self.decode_signals(frame)
        if decoded is None:
            return None
        _, s = decoded
        try:
            return AsStatus(frame.timestamp_s, AsState(int(s["AS_STATUS_STATE"])),
                            Mission(int(s["AS_STATUS_MISSION"])), int(s["LAP_COUNTER"]),
                            AssiMode(int(s["ASSI_MODE"])))
        except ValueError:
            self.rejects["bad_status"] += 1
            return None

    # -- encoding -------------------------------------------------------------------------

    def _counter(self, frame_id: int) -> int:
        value = self._counters[frame_id] % 16
        self._counters[frame_id] += 1
        return value

    def _encode(self, frame_id: int, timestamp_s: float, values: dict[str, float]) -> CanFrame:
        message = self._by_id[frame_id]
        data = message.encode(_clip(message, values), scaling=True, strict=False)
        return CanFrame(timestamp_s, frame_id, bytes(data))

    def encode_wheel_speeds(self, ws: WheelSpeeds) -> CanFrame:
        """A WHEEL_SPEEDS frame (1 mm/s steps, saturated at +-32.767 m/s)."""
        return self._encode(WHEEL_SPEEDS_ID, ws.timestamp_s, {
            "WHEEL_SPEED_FL": ws.front_left_mps, "WHEEL_SPEED_FR": ws.front_right_mps,
            "WHEEL_SPEED_RL": ws.rear_left_mps, "WHEEL_SPEED_RR": ws.rear_right_mps})

    def encode_steering(self, sa: SteeringAngle) -> CanFrame:
        """A STEERING_ANGLE frame (0.1 mrad steps) with its alive counter."""
        return self._encode(STEERING_ANGLE_ID, sa.timestamp_s, {
            "STEERING_ANGLE": sa.angle_rad, "STEERING_COUNTER": self._counter(STEERING_ANGLE_ID)})

    def encode_res(self, rs: RemoteStop) -> CanFrame:
        """A RES_STATE frame with its alive counter."""
        return self._encode(RES_STATE_ID, rs.timestamp_s, {
            "RES_EMERGENCY": float(rs.emergency), "RES_GO": float(rs.go),
            "RES_COUNTER": self._counter(RES_STATE_ID)})

    def encode_command(self, cmd: ActuatorCommand) -> CanFrame:
        """An AS_COMMAND frame with alive counter and checksum."""
        if not math.isfinite(cmd.steering_rad):  # ActuatorCommand already refuses this
            raise ValueError(f"steering_rad is not finite: {cmd.steering_rad!r}")
        frame = self._encode(AS_COMMAND_ID, cmd.timestamp_s, {
            "THROTTLE_CMD": cmd.throttle, "BRAKE_CMD": cmd.brake,
            "STEERING_CMD": cmd.steering_rad, "AS_STATE": float(int(cmd.state)),
            "ALIVE_COUNTER": self._counter(AS_COMMAND_ID), "CHECKSUM": 0.0})
        data = bytearray(frame.data)
        data[-1] = command_checksum(AS_COMMAND_ID, bytes(data))
        return CanFrame(frame.timestamp_s, AS_COMMAND_ID, bytes(data))

    def encode_mission(self, ms: MissionSelect) -> CanFrame:
        """A MISSION_SELECT frame (what the car sends) with its alive counter; the wire value
        is ``int(ms.mission)``."""
        return self._encode(MISSION_SELECT_ID, ms.timestamp_s, {
            "MISSION": float(int(ms.mission)), "MISSION_COUNTER": self._counter(MISSION_SELECT_ID)})

    def encode_as_status(self, st: AsStatus) -> CanFrame:
        """An AS_STATUS frame with its alive counter (the lap saturates at 255)."""
        return self._encode(AS_STATUS_ID, st.timestamp_s, {
            "AS_STATUS_STATE": float(int(st.state)), "ASSI_MODE": float(int(st.assi)),
            "AS_STATUS_MISSION": float(int(st.mission)),
            "AS_STATUS_COUNTER": self._counter(AS_STATUS_ID), "LAP_COUNTER": float(st.lap)})
