"""Every message type round-trips through an MCAP file; the file is standard MCAP + protobuf."""

from __future__ import annotations

import dataclasses
import enum
import math
from pathlib import Path

import numpy as np
import pytest
from mcap.reader import make_reader
from mcap_protobuf.decoder import DecoderFactory

from common.errors import RecordingError
from common.messages import (
    ActuatorCommand,
    AsState,
    Baseframe,
    CameraCones,
    CanFrame,
    ConeColour,
    ConeDetection,
    ConeMap,
    ConeSize,
    GpsFix,
    GroundTruth,
    Health,
    ImuSample,
    LidarCones,
    LidarPoints,
    MapState,
    Plan,
    PoseEstimate,
    RawBytes,
    RemoteStop,
    SourceHealth,
    SteeringAngle,
    TargetStates,
    WheelSpeeds,
)
from common.track import TrackLayout
from recordings import topics
from recordings.codec import from_proto, to_proto
from recordings.config import RecordingConfig
from recordings.player import Player
from recordings.reader import RecordingReader
from recordings.recorder import Recorder

RNG = np.random.default_rng(5)


def assert_same(a: object, b: object, where: str = "message") -> None:
    """Field-by-field exact equality (NaN equals NaN; arrays equal in shape, dtype, values)."""
    if isinstance(a, np.ndarray) or isinstance(b, np.ndarray):
        a_arr, b_arr = np.asarray(a), np.asarray(b)
        assert a_arr.shape == b_arr.shape, f"{where}: shape {a_arr.shape} != {b_arr.shape}"
        assert a_arr.dtype == b_arr.dtype, f"{where}: dtype {a_arr.dtype} != {b_arr.dtype}"
        if a_arr.dtype.kind == "f":
            # Bit-exact, so NaN and signed zeros count.
            assert a_arr.tobytes() == b_arr.tobytes(), f"{where}: values differ"
        else:
            assert np.array_equal(a_arr, b_arr), f"{where}: values differ"
        return
    if dataclasses.is_dataclass(a) and not isinstance(a, type):
        assert type(a) is type(b), f"{where}: {type(a).__name__} != {type(b).__name__}"
        for f in dataclasses.fields(a):
            assert_same(getattr(a, f.name), getattr(b, f.name), f"{where}.{f.name}")
        return
    if isinstance(a, tuple):
        assert isinstance(b, tuple) and len(a) == len(b), f"{where}: {a!r} != {b!r}"
        for i, (x, y) in enumerate(zip(a, b, strict=True)):
            assert_same(x, y, f"{where}[{i}]")
        return
    if isinstance(a, float):
        assert isinstance(b, float), f"{where}: {b!r} is not a float"
        assert math.copysign(1.0, a) == math.copysign(1.0, b) or math.isnan(a), where
        assert (math.isnan(a) and math.isnan(b)) or a == b, f"{where}: {a!r} != {b!r}"
        return
    if isinstance(a, enum.Enum):
        assert type(a) is type(b) and a == b, f"{where}: {a!r} != {b!r}"
        return
    assert type(a) is type(b) and a == b, f"{where}: {a!r} != {b!r}"


def _cones(n: int, t_s: float) -> tuple[ConeDetection, ...]:
    return tuple(
        ConeDetection(
            timestamp_s=t_s - 0.01 * i,
            x_m=float(RNG.normal(10, 5)),
            y_m=float(RNG.normal(0, 3)),
            colour=ConeColour(i % 5),
            size=ConeSize(i % 3),
            confidence=float(RNG.uniform()),
            height_m=math.nan if i % 2 else 0.325,
            width_m=-0.0 if i == 0 else 0.228,
        )
        for i in range(n)
    )


def _cone_map(n: int) -> ConeMap:
    cov = RNG.normal(size=(n, 2, 2))
    return ConeMap(
        xy_m=RNG.normal(size=(n, 2)) * 20,
        covariance=cov @ cov.transpose(0, 2, 1),
        colour=RNG.integers(0, 5, n),
        size=RNG.integers(0, 3, n),
        confidence=RNG.uniform(size=n),
        ids=RNG.integers(0, 2**40, n),
    )


def _pose(t_s: float) -> PoseEstimate:
    a = RNG.normal(size=(3, 3))
    return PoseEstimate(t_s, 1.5, -2.25, 3.0, 7.5, -0.1, 0.3, covariance=a @ a.T)


def _plan(t_s: float, with_baseframe: bool) -> Plan:
    k = 25
    manoeuvre = TargetStates(
        t_s=t_s + np.linspace(0, 2, k), x_m=RNG.normal(size=k), y_m=RNG.normal(size=k),
        yaw_rad=RNG.normal(size=k), speed_mps=RNG.uniform(0, 10, k),
        curvature_1pm=RNG.normal(size=k) * 0.1,
    )
    baseframe = None
    if with_baseframe:
        m = 200
        s = np.linspace(0, 300, m)
        baseframe = Baseframe(s, np.cos(s / 50) * 50, np.sin(s / 50) * 50, s / 50 + np.pi / 2,
                              np.full(m, 0.02), closed=True, length_m=300.0)
    return Plan(
        timestamp_s=t_s, baseframe=baseframe, manoeuvre=manoeuvre, target_speed_mps=8.5,
        candidates=tuple(RNG.normal(size=(10, 2)) for _ in range(3)), chosen_index=1,
        waypoints_xy_m=RNG.normal(size=(40, 2)), lap=2,
    )


def every_message(t_s: float = 1.0) -> list[tuple[str, object]]:
    """(topic, message) for every message type, with awkward values."""
    health = Health(
        t_s,
        sources=(
            SourceHealth(t_s, "gps", True, 10.0, 0.05, 0, False, (("checksum", 3), ("junk", 1))),
            SourceHealth(t_s, "lidar", False, 0.0, math.inf, 2, True),
        ),
        state=AsState.EMERGENCY,
        stop_reason="lidar stale",
    )
    track = TrackLayout(
        name="gen:7", cones_xy_m=RNG.normal(size=(30, 2)), colours=RNG.integers(0, 5, 30),
        sizes=RNG.integers(0, 3, 30), centreline_xy_m=RNG.normal(size=(50, 2)),
        left_xy_m=RNG.normal(size=(15, 2)), right_xy_m=RNG.normal(size=(15, 2)), width_m=3.0,
        is_loop=True, lap_length_m=250.0,
    )
    n = 500
    return [
        ("/gps/nmea", RawBytes(t_s, "gps", b"$GPGGA,123519,4807.038,N*47\r\n")),
        ("/imu/packet", RawBytes(t_s, "imu", bytes(range(256)) + b"\x00\x00")),
        ("/lidar/packet", RawBytes(t_s, "lidar", RNG.bytes(1206))),
        ("/camera/packet", RawBytes(t_s, "camera", b"")),
        ("/can/frame", CanFrame(t_s, 0x1FFFFFFF, b"\x00\xff\x10", is_extended_id=True)),
        ("/can/frame", CanFrame(t_s, 0x7FF, b"")),
        ("/gps/fix", GpsFix(t_s, -31.98, 115.82, 20.5, 4, 12, 0.8, 3.2, -2.5, 45296.25)),
        ("/gps/fix", GpsFix(t_s, 52.0, -0.0)),
        ("/imu/sample", ImuSample(t_s, 0.1, -0.2, 9.81, 1e-9, -1e300, 5e-324)),
        ("/can/wheels", WheelSpeeds(t_s, 10.0, 10.1, 9.9, -0.0)),
        ("/can/steering", SteeringAngle(t_s, -0.35)),
        ("/can/res", RemoteStop(t_s, True, False)),
        ("/detections/cone", ConeDetection(t_s, 3.0, -1.0)),
        ("/detections/lidar", LidarCones(t_s, _cones(7, t_s), sweep_start_s=t_s - 0.1,
                                         point_count=28000)),
        ("/detections/lidar", LidarCones(t_s, ())),
        ("/detections/camera", CameraCones(t_s, _cones(4, t_s), frame_id=2**40)),
        ("/lidar/points", LidarPoints(t_s, RNG.normal(size=(n, 4)), t_s + RNG.uniform(size=n),
                                      RNG.integers(0, 16, n))),
        ("/lidar/points", LidarPoints(t_s, RNG.normal(size=(n, 4)), t_s + RNG.uniform(size=n),
                                      RNG.integers(0, 16, n), return_count=28000,
                                      start_s=t_s - 0.1)),
        ("/pose", _pose(t_s)),
        ("/cones", _cone_map(12)),
        ("/cones", ConeMap.empty()),
        (topics.MAP_STATE, MapState(t_s, _pose(t_s), _cone_map(40), loop_closed=True,
                                    backend="ekf", map_frozen=True)),
        (topics.MAP_STATE, MapState(t_s, _pose(t_s), ConeMap.empty())),
        ("/baseframe", _plan(t_s, True).baseframe),
        ("/manoeuvre", _plan(t_s, False).manoeuvre),
        (topics.PLAN, _plan(t_s, True)),
        (topics.PLAN, _plan(t_s, False)),
        (topics.COMMAND, ActuatorCommand(t_s, 0.25, 0.0, -0.4, AsState.DRIVING)),
        (topics.COMMAND, ActuatorCommand.full_brake(t_s)),
        ("/health/source", health.sources[0]),
        (topics.HEALTH, health),
        (topics.TRUTH_POSE, GroundTruth(t_s, 1.0, 2.0, -3.1, 10.0, 0.2, -0.5, 0.1)),
        (topics.TRUTH_TRACK, track),
    ]


def test_codec_round_trip_in_memory() -> None:
    for topic, message in every_message():
        proto = to_proto(message)
        back = from_proto(type(proto).FromString(proto.SerializeToString()))
        assert_same(message, back, topic)


def test_codec_rejects_unknown_types() -> None:
    with pytest.raises(RecordingError):
        to_proto(object())


def test_every_type_round_trips_through_a_file(tmp_path: Path) -> None:
    path = tmp_path / "all.mcap"
    messages = every_message()
    # Distinct topics per type: a topic carries one schema.
    by_topic: dict[str, list[object]] = {}
    for topic, message in messages:
        by_topic.setdefault(f"{topic}/{type(message).__name__}", []).append(message)
    with Recorder(path) as recorder:
        for i, (topic, message) in enumerate(messages):
            assert recorder.write(f"{topic}/{type(message).__name__}", message, 1.0 + 0.001 * i)
    assert recorder.dropped == 0 and recorder.errors == 0
    played: dict[str, list[object]] = {}
    player = Player(path)
    for _, topic, message in player:
        played.setdefault(topic, []).append(message)
    assert not player.recovered and player.decode_errors == 0
    assert set(played) == set(by_topic)
    for topic, sent in by_topic.items():
        assert len(played[topic]) == len(sent), topic
        for a, b in zip(sent, played[topic], strict=True):
            assert_same(a, b, topic)


def test_raw_units_go_to_their_topics_and_log_time_is_the_unit_time(tmp_path: Path) -> None:
    path = tmp_path / "raw.mcap"
    raws = [
        RawBytes(0.5, "gps", b"$GPRMC\r\n"), RawBytes(0.6, "imu", b"\xfa\x01"),
        RawBytes(0.7, "lidar", b"\xff\xee" * 603), RawBytes(0.8, "camera", b"\x08\x01"),
        CanFrame(0.9, 0x100, b"\x01"), RawBytes(1.1, "radar", b"x"),
    ]
    with Recorder(path) as recorder:
        for raw in raws:
            recorder.write_raw(raw)
    out = list(Player(path))
    assert [t for _, t, _ in out] == [
        "/gps/nmea", "/imu/packet", "/lidar/packet", "/camera/packet", "/can/frame", "/raw/radar"
    ]
    assert [t for t, _, _ in out] == [round(r.timestamp_s * 1e9) * 1e-9 for r in raws]
    for raw, (_, _, back) in zip(raws, out, strict=True):
        assert_same(raw, back)


def test_foxglove_views_are_written_and_decode_with_the_standard_reader(tmp_path: Path) -> None:
    path = tmp_path / "fox.mcap"
    messages = dict((t, m) for t, m in every_message(2.0) if t.startswith(("/map", "/plan",
                                                                          "/truth/track")))
    with Recorder(path) as recorder:
        recorder.write(topics.TRUTH_TRACK, messages[topics.TRUTH_TRACK], 0.0)
        recorder.write(topics.MAP_STATE, messages[topics.MAP_STATE], 2.0)
        recorder.write(topics.PLAN, messages[topics.PLAN], 2.01)
        recorder.write_gps_fix(GpsFix(2.02, -31.98, 115.82, 20.0, hdop=1.2))
    # The standard mcap reader with schema-driven decoding (what Foxglove does).
    schemas: dict[str, str] = {}
    decoded: dict[str, list[object]] = {}
    with open(path, "rb") as f:
        reader = make_reader(f, decoder_factories=[DecoderFactory()])
        for schema, channel, _message, proto in reader.iter_decoded_messages():
            assert schema is not None
            schemas[channel.topic] = schema.name
            decoded.setdefault(channel.topic, []).append(proto)
    assert schemas[topics.FOXGLOVE_SCENE] == "foxglove.SceneUpdate"
    assert schemas[topics.FOXGLOVE_GPS] == "foxglove.LocationFix"
    assert schemas[topics.MAP_STATE] == "fsd.MapState"
    scenes = decoded[topics.FOXGLOVE_SCENE]
    entity_ids = [e.id for scene in scenes for e in scene.entities]  # type: ignore[attr-defined]
    assert entity_ids == ["truth_track", "cones", "car", "plan"]
    cones_entity = scenes[1].entities[0]  # type: ignore[attr-defined]
    assert len(cones_entity.cylinders) == len(messages[topics.MAP_STATE].cones)  # type: ignore
    assert cones_entity.frame_id == "world"
    fix = decoded[topics.FOXGLOVE_GPS][0]
    assert fix.latitude == -31.98 and fix.longitude == 115.82  # type: ignore[attr-defined]
    assert fix.timestamp.seconds == 2 and fix.timestamp.nanos == 20_000_000  # type: ignore


def test_foxglove_views_can_be_switched_off(tmp_path: Path) -> None:
    path = tmp_path / "nofox.mcap"
    state = next(m for t, m in every_message() if t == topics.MAP_STATE)
    with Recorder(path, RecordingConfig(foxglove=False)) as recorder:
        recorder.write(topics.MAP_STATE, state, 1.0)
        recorder.write_gps_fix(GpsFix(1.0, 1.0, 2.0))
    with RecordingReader(path) as reader:
        assert set(reader.topics) == {topics.MAP_STATE}


def test_a_topic_keeps_its_type(tmp_path: Path) -> None:
    path = tmp_path / "mixed.mcap"
    with Recorder(path) as recorder:
        recorder.write("/x", SteeringAngle(0.0, 0.1), 0.0)
        recorder.write("/x", RemoteStop(0.1, False, True), 0.1)  # refused, counted
        recorder.write("/x", SteeringAngle(0.2, 0.2), 0.2)
        recorder.write("/y", object(), 0.3)  # no schema: refused, counted
        recorder.write("/x", SteeringAngle(0.4, 0.4), math.nan)  # no log time: refused
        recorder.write("/x", SteeringAngle(-1.0, 0.4), -1.0)  # MCAP times are unsigned
    assert recorder.errors == 4
    assert [m for _, _, m in Player(path)] == [SteeringAngle(0.0, 0.1), SteeringAngle(0.2, 0.2)]


def test_metadata_is_stored(tmp_path: Path) -> None:
    path = tmp_path / "meta.mcap"
    with Recorder(path, metadata={"track": "default", "seed": 3}) as recorder:
        recorder.add_metadata("config", {"toml": "[car]\nname = 'x'\n"})
        recorder.write(topics.COMMAND, ActuatorCommand(0.0, 0.0, 0.0, 0.0), 0.0)
    player = Player(path)
    assert player.metadata["fsd"] == {"track": "default", "seed": "3"}
    assert player.metadata["config"]["toml"].startswith("[car]")


def test_the_simulators_track_records_as_the_one_track_type() -> None:
    from simulator.tracks import load_track

    track = load_track("default")
    back = from_proto(to_proto(track))
    assert type(back) is TrackLayout and back.name == "default"
    for name in ("cones_xy_m", "colours", "sizes", "centreline_xy_m", "left_xy_m", "right_xy_m"):
        np.testing.assert_array_equal(getattr(back, name), getattr(track, name))
    assert (back.width_m, back.is_loop, back.lap_length_m) == (
        track.width_m, track.is_loop, track.lap_length_m)
