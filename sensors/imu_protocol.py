"""The IMU's serial protocol: VectorNav binary output (VN-100 / VN-200 / VN-300 family).

Wire format of one binary output packet, as documented in VectorNav's user manuals
("Binary Output" section), all multi-byte values little-endian except the CRC:

====== ============ ==========================================================================
offset size         content
====== ============ ==========================================================================
0      1            sync byte ``0xFA``
1      1            groups: bit mask of the output groups present (bit 0 = group 1 "Common")
2      2 per group  for each group present, its 16-bit field mask (little-endian)
...    ...          the selected fields, group by group, field by field in bit order
end-2  2            CRC-16-CCITT (polynomial 0x1021, initial value 0, no reflection, i.e.
                    CRC-16/XMODEM) of every byte after the sync byte up to the CRC, sent
                    big-endian, so the CRC over everything after the sync byte, CRC included,
                    is 0
====== ============ ==========================================================================

Group 1 ("Common") fields and sizes (bytes): bit 0 TimeStartup (u64, ns since power-on, 8),
1 TimeGps (8), 2 TimeSyncIn (8), 3 YawPitchRoll (3 x f32, 12), 4 Quaternion (16),
5 AngularRate (3 x f32, rad/s, 12), 6 Position (3 x f64, 24), 7 Velocity (12),
8 Accel (3 x f32, m/s^2, 12), 9 Imu (6 x f32, 24), 10 MagPres (20), 11 DeltaThetaVel (28),
12 InsStatus (2), 13 SyncInCnt (4), 14 TimeGpsPps (8).

We configure the unit for group 1 with TimeStartup, AngularRate and Accel (field mask
``0x0121``): a 38-byte packet ``FA 01 21 01 <u64><3 f32><3 f32><crc16>``, at 200 Hz.
:class:`ImuParser` reads any group-1 packet that holds AngularRate and Accel; packets with
other groups are counted as ``unsupported`` (their field sizes are not tabled here).

Frames. The sensor's body frame is x forward, y right, z down (VectorNav's convention); it
measures specific force, so at rest ``Accel`` reads about (0, 0, -9.81). It is mounted aligned
with the car, so the conversion to the vehicle frame (x forward, y left, z up) negates y and z:
at rest an :class:`ImuSample` reads ``accel_z_mps2`` = +9.81.

Time. ``ImuSample.timestamp_s`` is on the Clock of the receiving side. With TimeStartup
present, samples are stamped ``sensor_time + offset``, the offset being the smallest
(receive time - sensor time) seen so far, allowed to creep up by :data:`CLOCK_DRIFT_ALLOWANCE`
per second of sensor time (so serial batching does not bunch samples together and a sample is
never stamped after it was received); a sensor clock that jumps back (a restart) resets it.

Rejects (``ImuParser.rejects``): ``bad_crc``, ``truncated`` (a packet interrupted by the header of
the next one, or left incomplete at :meth:`ImuParser.flush`), ``nan`` (NaN or infinite
values: counted, never passed on), ``unsupported`` (groups or fields we cannot read, or no
rate/acceleration), ``junk`` (one per run of bytes outside any packet).
"""

from __future__ import annotations

import binascii
import collections
import logging
import math
import struct

from common.messages import ImuSample

log = logging.getLogger(__name__)

SYNC = 0xFA
GROUP_COMMON = 0x01
FIELD_TIME_STARTUP = 1 << 0
FIELD_ANGULAR_RATE = 1 << 5
FIELD_ACCEL = 1 << 8
DEFAULT_FIELDS = FIELD_TIME_STARTUP | FIELD_ANGULAR_RATE | FIELD_ACCEL
"""Field mask our IMU is configured to send (0x0121)."""

GROUP1_FIELD_SIZES = (8, 8, 8, 12, 16, 12, 24, 12, 12, 24, 20, 28, 2, 4, 8)
"""Size in bytes of each group-1 field, by bit number 0..14."""

PACKET_BYTES = 1 + 1 + 2 + 8 + 12 + 12 + 2
"""Length of the default packet (38 bytes)."""

MAX_PACKET_BYTES = 1 + 1 + 2 + sum(GROUP1_FIELD_SIZES) + 2

CLOCK_DRIFT_ALLOWANCE = 1e-4
"""How fast the sensor-to-Clock offset may grow (s per s of sensor time, 100 ppm)."""

_F32x3 = struct.Struct("<3f")
_U64 = struct.Struct("<Q")
_CRC = struct.Struct(">H")
_DEFAULT_BODY = struct.Struct("<BHQ3f3f")
"""Groups, field mask, TimeStartup, AngularRate, Accel: the default packet after the sync."""


def crc16(data: bytes) -> int:
    """VectorNav's CRC-16-CCITT (poly 0x1021, init 0; CRC-16/XMODEM) of ``data``."""
    return binascii.crc_hqx(data, 0)


def encode_imu_packet(sample: ImuSample, sensor_time_s: float | None = None) -> bytes:
    """One binary packet (group 1: TimeStartup, AngularRate, Accel) for ``sample``.

    ``sensor_time_s`` is the sensor's time since power-on (s; default ``sample.timestamp_s``).
    Values are converted to the sensor frame (y and z negated) and rounded to float32.
    """
    t = sample.timestamp_s if sensor_time_s is None else sensor_time_s
    t_ns = int(round(t * 1e9)) if math.isfinite(t) and t > 0 else 0
    body = _DEFAULT_BODY.pack(
        GROUP_COMMON, DEFAULT_FIELDS, min(t_ns, 2**64 - 1),
        sample.gyro_x_radps, -sample.gyro_y_radps, -sample.gyro_z_radps,
        sample.accel_x_mps2, -sample.accel_y_mps2, -sample.accel_z_mps2)
    return b"\xfa" + body + _CRC.pack(crc16(body))


def _packet_length(buf: bytearray | bytes) -> int | str:
    """Length of the packet starting at ``buf[0]`` (a sync byte), or a reject reason, or 0
    when more bytes are needed to tell."""
    if len(buf) < 4:
        return 0
    if buf[1] != GROUP_COMMON:
        return "unsupported"
    fields = buf[2] | (buf[3] << 8)
    length = _LENGTHS.get(fields)
    if length is None:
        if fields == 0 or fields >> len(GROUP1_FIELD_SIZES):
            return "unsupported"
        size = sum(s for bit, s in enumerate(GROUP1_FIELD_SIZES) if fields >> bit & 1)
        length = _LENGTHS[fields] = 4 + size + 2
    return length


_LENGTHS: dict[int, int] = {}
"""Packet length by group-1 field mask (filled as masks are seen)."""


class ImuParser:
    """VectorNav binary packets in any chunking to :class:`ImuSample` messages.

    ``feed`` never raises; bad input is counted in ``rejects`` and the parser resynchronises
    on the next sync byte.
    """

    source = "imu"

    def __init__(self, use_sensor_time: bool = True) -> None:
        self.use_sensor_time = use_sensor_time
        self.rejects: collections.Counter[str] = collections.Counter()
        self.counts: collections.Counter[str] = collections.Counter()
        self._buf = bytearray()
        self._in_junk = False
        self._offset_s: float | None = None
        self._last_sensor_s: float | None = None
        self._last_receive_s = 0.0
        self._good_header = b""
        """Header (first 4 bytes) of the last packet that passed its CRC."""

    def reset(self) -> None:
        """Forget partial packets and the clock offset (after a reconnection)."""
        self._buf.clear()
        self._in_junk = False
        self._offset_s = None
        self._last_sensor_s = None

    def feed(self, timestamp_s: float, data: bytes) -> list[ImuSample]:
        """Take bytes received at ``timestamp_s`` (Clock, s); return the samples completed."""
        out: list[ImuSample] = []
        try:
            self._last_receive_s = timestamp_s
            self._buf += data
            self._drain(timestamp_s, out)
        except Exception:  # pragma: no cover - defensive: a parser must not kill its thread
            log.exception("IMU parser failed; buffer dropped")
            self._buf.clear()
            self.rejects["garbled"] += 1
        return out

    def flush(self, timestamp_s: float | None = None) -> list[ImuSample]:
        """End of stream: the incomplete packet at the head of the buffer is counted as
        truncated and the rest is searched for complete packets (returned)."""
        out: list[ImuSample] = []
        stamp = self._last_receive_s if timestamp_s is None else timestamp_s
        try:
            while self._buf:
                self._drain(stamp, out)
                if self._buf:
                    self._drop(1, "truncated" if self._buf[0] == SYNC else "junk")
        except Exception:  # pragma: no cover - defensive
            log.exception("IMU parser flush failed")
            self._buf.clear()
        return out

    # -- internals ------------------------------------------------------------------------

    def _drain(self, timestamp_s: float, out: list[ImuSample]) -> None:
        buf = self._buf
        while buf:
            if buf[0] != SYNC:
                start = buf.find(SYNC)
                if not self._in_junk:
                    self.rejects["junk"] += 1
                    self._in_junk = True
                if start < 0:
                    buf.clear()
                    return
                del buf[:start]
            length = _packet_length(buf)
            if length == 0:
                return
            if isinstance(length, str):
                self._drop(1, length)
                continue
            if len(buf) < length:
                # Wait for more bytes, unless the next packet already started: a repeat of
                # this header (this one was cut short), or, when this header is not the one
                # the unit has been sending, that one (this one is a corrupted header).
                header = bytes(buf[:4])
                nxt = buf.find(header, 1)
                if nxt > 0:
                    self._drop(nxt, "truncated")
                    continue
                good = self._good_header
                if good and header != good and buf.find(good, 1) > 0:
                    self._drop(buf.find(good, 1), "truncated")
                    continue
                return
            packet = bytes(buf[:length])
            if crc16(packet[1:]) != 0:
                # Cut short by the next packet (its header inside this span), or corrupted.
                nxt = buf.find(packet[:4], 1, length)
                if nxt < 0 and self._good_header:
                    nxt = buf.find(self._good_header, 1, length)
                if nxt > 0:
                    self._drop(nxt, "truncated")
                else:
                    self._drop(1, "bad_crc")
                continue
            del buf[:length]
            self._in_junk = False
            self._good_header = packet[:4]
            sample = self._decode(timestamp_s, packet)
            if sample is not None:
                out.append(sample)

    def _drop(self, count: int, reason: str) -> None:
        self.rejects[reason] += 1
        log.debug("IMU reject %s (%d bytes dropped)", reason, count)
        del self._buf[:count]
        self._in_junk = False

    def _decode(self, timestamp_s: float, packet: bytes) -> ImuSample | None:
        fields = packet[2] | (packet[3] << 8)
        if not (fields & FIELD_ANGULAR_RATE and fields & FIELD_ACCEL):
            self.rejects["unsupported"] += 1
            return None
        pos = 4
        sensor_s: float | None = None
        gyro = accel = (0.0, 0.0, 0.0)
        if fields == DEFAULT_FIELDS:  # fast path: the packet our unit is configured to send
            _, _, t_ns, gx, gy, gz, ax, ay, az = _DEFAULT_BODY.unpack_from(packet, 1)
            sensor_s, gyro, accel = t_ns * 1e-9, (gx, gy, gz), (ax, ay, az)
            fields = 0
        for bit, size in enumerate(GROUP1_FIELD_SIZES if fields else ()):
            if not fields >> bit & 1:
                continue
            if bit == 0:
                sensor_s = _U64.unpack_from(packet, pos)[0] * 1e-9
            elif bit == 5:
                gyro = _F32x3.unpack_from(packet, pos)
            elif bit == 8:
                accel = _F32x3.unpack_from(packet, pos)
            pos += size
        values = gyro + accel
        if not math.isfinite(sum(values)):  # NaN or inf anywhere (float32 sums cannot overflow)
            self.rejects["nan"] += 1
            log.debug("IMU packet with non-finite values rejected: %r", values)
            return None
        self.counts["packets"] += 1
        stamp = self._stamp(timestamp_s, sensor_s)
        return ImuSample(
            timestamp_s=stamp,
            accel_x_mps2=accel[0],
            accel_y_mps2=-accel[1],
            accel_z_mps2=-accel[2],
            gyro_x_radps=gyro[0],
            gyro_y_radps=-gyro[1],
            gyro_z_radps=-gyro[2],
        )

    def _stamp(self, receive_s: float, sensor_s: float | None) -> float:
        """Clock time of a sample received at ``receive_s`` with sensor time ``sensor_s``."""
        if not self.use_sensor_time or sensor_s is None:
            return receive_s
        delay = receive_s - sensor_s
        last = self._last_sensor_s
        if self._offset_s is None or last is None or sensor_s < last:
            self._offset_s = delay
        else:
            self._offset_s = min(self._offset_s + CLOCK_DRIFT_ALLOWANCE * (sensor_s - last),
                                 delay)
        self._last_sensor_s = sensor_s
        return sensor_s + self._offset_s
