"""Seed inputs for ``bench fuzz``: real captures from ``../shared/data``, read at run time.

Nothing here is copied into the repository; each function reads the shared data folder and
returns the inputs one parser takes, in that parser's wire format:

- ``nmea``: windows of 1..16 lines of the 12 receivers' NMEA captures (``nmea/*.log``);
- ``imu``: the comma2k19 drive's 100 Hz accelerometer and gyro (``vehicle_logs``) encoded as
  our IMU's VectorNav packets, 1..8 packets per input;
- ``can``: the RAV4's CAN frames (``can/*candump.log``) plus the same drive's wheel speeds and
  steering angle encoded as our car's frames (``sensors/car.dbc``), as :func:`frame_bytes`;
- ``lidar``, ``lidar-hdl32e``, ``lidar-os1``: the VLP-16's, the HDL-32E's and the Ouster
  OS1-64's captures' UDP datagrams, in order;
- ``camera``: ``CameraCones`` datagrams of what a camera sees of the real cone layouts
  (``tracks/``) from poses along them;
- ``mcap``: a small recording of the above, written by our own :class:`Recorder`, and the same
  without compression or CRCs.
"""

from __future__ import annotations

import math
import re
import tempfile
from pathlib import Path

import numpy as np

from common.messages import (
    CameraCones,
    CanFrame,
    ConeColour,
    ConeDetection,
    ImuSample,
    RawBytes,
    SteeringAngle,
    WheelSpeeds,
)

ROOT = Path(__file__).resolve().parents[1]
DEFAULT_DATA = ROOT.parent / "shared" / "data"
"""The shared data folder beside the project (``../shared/data``)."""
COMMA = Path("vehicle_logs") / "comma2k19_rav4_seg40" / "processed_log"
_CANDUMP_LINE = re.compile(rb"^\(([0-9.]+)\)\s+\S+\s+([0-9A-Fa-f]+)#([0-9A-Fa-f]*)")


def frame_bytes(frame: CanFrame) -> bytes:
    """A CAN frame as fuzz input: the id (4 bytes big-endian, bit 31 = extended) + data."""
    word = frame.arbitration_id | (1 << 31 if frame.is_extended_id else 0)
    return word.to_bytes(4, "big") + frame.data


def bytes_frame(data: bytes, timestamp_s: float) -> CanFrame:
    """The inverse of :func:`frame_bytes` for any bytes (short input: a zero-padded id)."""
    head = data[:4].rjust(4, b"\x00")
    word = int.from_bytes(head, "big")
    extended = bool(word >> 31)
    return CanFrame(timestamp_s, word & (0x1FFFFFFF if extended else 0x7FF), data[4:], extended)


def _need(path: Path) -> Path:
    if not path.exists():
        raise FileNotFoundError(f"{path}: shared data missing (bench fuzz reads ../shared/data)")
    return path


def nmea_seeds(data_dir: Path) -> list[bytes]:
    """Windows of 1..16 lines of every NMEA capture (comment lines dropped)."""
    from sensors.cli import strip_comment_lines

    rng = np.random.default_rng(11)
    seeds: list[bytes] = []
    for log in sorted(_need(data_dir / "nmea").glob("*.log")):
        lines = strip_comment_lines(log.read_bytes()).splitlines(keepends=True)
        i = 0
        while i < len(lines):
            n = int(rng.integers(1, 17))
            seeds.append(b"".join(lines[i:i + n]))
            i += max(1, n // 2)
    return seeds


def imu_samples(data_dir: Path) -> list[ImuSample]:
    """The comma2k19 drive's IMU samples (device frame taken as the vehicle frame)."""
    base = _need(data_dir / COMMA / "IMU")
    t = np.load(base / "accelerometer" / "t")
    acc = np.load(base / "accelerometer" / "value")
    gyr = np.load(base / "gyro" / "value")
    n = min(len(t), len(acc), len(gyr))
    t0 = float(t[0])
    return [ImuSample(float(t[i]) - t0 + 1.0, *map(float, acc[i]), *map(float, gyr[i]))
            for i in range(n)]


def imu_seeds(data_dir: Path) -> list[bytes]:
    """1..8 consecutive VectorNav packets of the real IMU samples per input."""
    from sensors.imu_protocol import encode_imu_packet

    packets = [encode_imu_packet(s) for s in imu_samples(data_dir)]
    rng = np.random.default_rng(12)
    seeds = []
    i = 0
    while i < len(packets):
        n = int(rng.integers(1, 9))
        seeds.append(b"".join(packets[i:i + n]))
        i += n
    return seeds


def can_frames(data_dir: Path) -> list[CanFrame]:
    """The RAV4 candump's frames, then the drive's speeds and steering as our car's frames."""
    from sensors.can_codec import CanCodec

    frames = []
    for line in _need(data_dir / "can").glob("*candump.log"):
        for raw in line.read_bytes().splitlines():
            m = _CANDUMP_LINE.match(raw)
            if m:
                ident = int(m.group(2), 16)
                frames.append(CanFrame(float(m.group(1)), ident, bytes.fromhex(m.group(3).decode()),
                                       len(m.group(2)) > 3))
    codec = CanCodec()
    base = _need(data_dir / COMMA / "CAN")
    t = np.load(base / "wheel_speed" / "t")
    wheels = np.load(base / "wheel_speed" / "value")
    steer = np.load(base / "steering_angle" / "value")
    for i in range(0, len(t), 5):
        ts = float(t[i])
        frames.append(codec.encode_wheel_speeds(WheelSpeeds(ts, *map(float, wheels[i]))))
        frames.append(codec.encode_steering(SteeringAngle(ts, math.radians(float(steer[i])))))
    return frames


def can_seeds(data_dir: Path) -> list[bytes]:
    """Every frame of :func:`can_frames` as :func:`frame_bytes`."""
    return [frame_bytes(f) for f in can_frames(data_dir)]


def _pcap_payloads(pcap: Path) -> list[bytes]:
    from sensors.decode_lidar import read_pcap_udp

    return [payload for _, _, payload in read_pcap_udp(_need(pcap))]


def lidar_seeds(data_dir: Path) -> list[bytes]:
    """The VLP-16 capture's UDP payloads in capture order."""
    return _pcap_payloads(data_dir / "lidar" / "velodyne_vlp16.pcap")


def hdl32e_seeds(data_dir: Path) -> list[bytes]:
    """The HDL-32E capture's UDP payloads in capture order."""
    return _pcap_payloads(data_dir / "lidar" / "velodyne_hdl32e.pcap")


def os1_seeds(data_dir: Path) -> list[bytes]:
    """The Ouster OS1-64 capture's UDP payloads in capture order."""
    return _pcap_payloads(data_dir / "lidar" / "ouster_example.pcap")


def camera_messages(data_dir: Path, count: int = 300) -> list[CameraCones]:
    """What a camera 0..20 m ahead sees of the real cone layouts, from poses on them."""
    from simulator.tracks import load_track

    rng = np.random.default_rng(13)
    files = sorted((_need(data_dir / "tracks") / "eufs").glob("*.csv"))
    files += sorted((data_dir / "tracks" / "amz_fssim").glob("*.yaml"))
    tracks = [load_track(str(f)) for f in files]
    out = []
    for k in range(count):
        track = tracks[k % len(tracks)]
        centre = track.centreline_xy_m[int(rng.integers(len(track.centreline_xy_m)))]
        yaw = float(rng.uniform(-math.pi, math.pi))
        rel = track.cones_xy_m - centre
        c, s = math.cos(yaw), math.sin(yaw)
        x = c * rel[:, 0] + s * rel[:, 1]
        y = -s * rel[:, 0] + c * rel[:, 1]
        seen = np.flatnonzero((x > 0.5) & (x < 20.0) & (np.abs(y) < x))
        t = 10.0 + 0.05 * k
        cones = tuple(ConeDetection(t, float(x[i]), float(y[i]), ConeColour(int(track.colours[i])),
                                    confidence=float(rng.uniform(0.5, 1.0))) for i in seen)
        out.append(CameraCones(t, cones, k))
    return out


def camera_seeds(data_dir: Path) -> list[bytes]:
    """:func:`camera_messages` as datagrams."""
    from sensors.camera_codec import encode_camera_cones

    return [encode_camera_cones(m) for m in camera_messages(data_dir)]


def mcap_seeds(data_dir: Path) -> list[bytes]:
    """A small recording (a dozen chunks) of real NMEA, IMU, CAN, LiDAR and camera data, as
    our recorder writes it (zstd, CRCs) and as a plain copy (:func:`_plain_copy`)."""
    from recordings.config import RecordingConfig
    from recordings.recorder import Recorder
    from sensors.camera_codec import encode_camera_cones

    nmea = nmea_seeds(data_dir)[:40]
    imu = imu_seeds(data_dir)[:40]
    can = can_frames(data_dir)[:60]
    lidar = lidar_seeds(data_dir)[:3]
    camera = camera_messages(data_dir, 5)
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / "seed.mcap"
        config = RecordingConfig(chunk_duration_s=0.05, foxglove=False)
        with Recorder(path, config, blocking=True, metadata={"track": "fuzz"}) as recorder:
            for i in range(40):
                t = 0.01 * i
                recorder.write_raw(RawBytes(t, "gps", nmea[i]))
                recorder.write_raw(RawBytes(t, "imu", imu[i]))
                recorder.write_raw(CanFrame(t, can[i].arbitration_id, can[i].data,
                                            can[i].is_extended_id))
                if i < len(lidar):
                    recorder.write_raw(RawBytes(t, "lidar", lidar[i]))
                if i < len(camera):
                    recorder.write_raw(RawBytes(t, "camera", encode_camera_cones(camera[i])))
                    recorder.write("/camera/cones", camera[i], t)
        return [path.read_bytes(), _plain_copy(path)]


def _plain_copy(path: Path) -> bytes:
    """The recording at ``path`` rewritten without compression and without CRCs (as other
    writers may leave it), so mutations reach the records and messages, not just a CRC."""
    import io

    from mcap.writer import CompressionType
    from mcap.writer import Writer as McapWriter

    from recordings.reader import RecordingReader

    out = io.BytesIO()
    writer = McapWriter(out, chunk_size=4096, compression=CompressionType.NONE,
                        enable_crcs=False)
    writer.start(profile="", library="fuzz seed")
    with RecordingReader(path) as reader:
        schema_ids = {sid: writer.register_schema(s.name, s.encoding, s.data)
                      for sid, s in reader.schemas.items()}
        channel_ids = {cid: writer.register_channel(c.topic, c.message_encoding,
                                                    schema_ids.get(c.schema_id, 0))
                       for cid, c in reader.channels.items()}
        for message in reader.iter_messages():
            writer.add_message(channel_ids[message.channel_id], message.log_time_ns,
                               message.data, message.log_time_ns)
    writer.finish()
    return out.getvalue()


SEEDS = {
    "nmea": nmea_seeds,
    "imu": imu_seeds,
    "can": can_seeds,
    "lidar": lidar_seeds,
    "lidar-hdl32e": hdl32e_seeds,
    "lidar-os1": os1_seeds,
    "camera": camera_seeds,
    "mcap": mcap_seeds,
}
"""Seed builder of each parser, by the name ``bench fuzz`` reports it under."""
