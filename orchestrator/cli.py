"""Subcommands of Tier 1: ``sim``, ``replay``, ``record``, ``drive``, ``emulate`` and ``render``."""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path
from typing import Any

from common.cli_types import (
    host_port,
    int_in,
    non_negative_int,
    positive_float,
    positive_int,
    positive_seconds,
    size_wxh,
    stall_window,
)
from common.errors import FsdError
from orchestrator.config import MISSIONS, AppConfig
from simulator.faults import fault_spec


def register(subparsers: Any, common: argparse.ArgumentParser) -> None:
    """Add Main's subcommands."""
    sim = subparsers.add_parser(
        "sim", parents=[common],
        help="closed-loop simulation: exploration lap, loop closure, autonomous laps (default)",
    )
    sim.add_argument("--track", help="'default', 'gen:SEED', or a track file (.csv EUFS, .yaml "
                     "FSSIM)")
    sim.add_argument("--laps", type=positive_int,
                     help="autonomous laps, >= 1 (default: config mission.laps)")
    sim.add_argument("--seed", type=non_negative_int,
                     help="random seed of the simulated world (>= 0)")
    _add_mission_options(sim)
    sim.add_argument("--mapper", choices=("slam", "smoother"), help="mapping backend")
    sim.add_argument("--out", type=Path, help="run folder (default: runs/<date-time>/)")
    render = sim.add_mutually_exclusive_group()
    render.add_argument("--render", dest="render", action="store_true", default=None,
                        help="render PNG frames and a movie of the run")
    render.add_argument("--no-render", dest="render", action="store_false",
                        help="do not render frames")
    sim.add_argument("--no-record", dest="record", action="store_false", default=None,
                     help="do not write recording.mcap")
    sim.add_argument("--realtime", action="store_true",
                     help="pace the simulation to the wall clock")
    sim.add_argument("--fault", type=fault_spec, action="append", default=[],
                     metavar="KIND@T[:DURATION]",
                     help="inject a fault: estop, gps-dropout, lidar-dead, imu-nan, can-garbage, "
                     "camera-dead (repeatable)")
    _add_live(sim)
    sim.add_argument("--json", action="store_true", help="print the summary as JSON")
    sim.add_argument("--profile", action="store_true",
                     help="also print the budget table: wall ms per simulated second in the "
                     "simulator, sensor decoding, Mapper, planner, controller and outputs")
    sim.set_defaults(func=_sim)

    replay = subparsers.add_parser(
        "replay", parents=[common],
        help="feed a recording's raw sensor data through the stack (deterministic at any rate)",
    )
    replay.add_argument("recording", type=Path,
                        help="an .mcap recording, or 'sample' (one simulated exploration lap, "
                        "made on first use)")
    pace = replay.add_mutually_exclusive_group()
    pace.add_argument("--rate", type=positive_float, default=None,
                      help="replay rate on the recording's clock (1 = real time)")
    pace.add_argument("--max", action="store_true", help="as fast as possible (default)")
    replay.add_argument("--out", type=Path, help="folder for summary.json (and frames)")
    replay.add_argument("--render", action="store_true", help="render frames into OUT/frames")
    replay.add_argument("--json", action="store_true", help="print the summary as JSON")
    replay.add_argument("--single-process", action="store_true",
                        help="read and parse the recording in Main's own process (by default "
                             "a second process does it beside Main; same outputs either way)")
    _add_live(replay)
    replay.set_defaults(func=_replay)

    imp = subparsers.add_parser(
        "import", parents=[common],
        help="convert a foreign vehicle log (comma2k19) into a recording of our sensors' bytes",
    )
    imp.add_argument("format", help="the log's format (comma2k19)")
    imp.add_argument("source", type=Path, help="the log (a comma2k19 segment folder)")
    imp.add_argument("--out", type=Path, required=True, help="the recording to write (.mcap)")
    imp.add_argument("--drop-gnss", metavar="START_S:DURATION_S", default=None,
                     help="leave out the GNSS fixes of this window (s after the log's start)")
    imp.add_argument("--json", action="store_true", help="print what was written as JSON")
    imp.set_defaults(func=_import)

    drive = subparsers.add_parser(
        "drive", parents=[common],
        help="drive the real car: live sensors, commands out on CAN, recording on",
    )
    drive.add_argument("--laps", type=positive_int,
                       help="autonomous laps, >= 1 (default: config mission.laps)")
    _add_mission_options(drive)
    drive.add_argument("--out", type=Path, help="run folder (default: runs/<date-time>/)")
    drive.add_argument("--no-record", dest="record", action="store_false", default=True)
    drive.add_argument("--seconds", type=positive_seconds, help="stop after this long (s)")
    drive.add_argument("--render", action="store_true", help="render frames of the map")
    drive.add_argument("--rt-priority", type=int_in(0, 99), default=None, metavar="N",
                       help="SCHED_FIFO priority of the control loop, with both processes' memory "
                            "locked in RAM (default 10; 0: neither)")
    _add_live(drive)
    drive.set_defaults(func=_drive)

    record = subparsers.add_parser(
        "record", parents=[common], help="record live sensors to an MCAP file, no control"
    )
    record.add_argument("--out", type=Path, required=True, help="the .mcap file to write")
    record.add_argument("--seconds", type=positive_seconds, help="stop after this long (s)")
    record.set_defaults(func=_record)

    emulate = subparsers.add_parser(
        "emulate", parents=[common],
        help="serve the simulated car over real transports (pty serial, slcan CAN, UDP) for drive",
    )
    emulate.add_argument("--track", default="default", help="track name or file")
    emulate.add_argument("--seconds", type=positive_seconds, help="stop after this long (s)")
    _add_mission_options(emulate)
    emulate.add_argument("--write-config", type=Path, metavar="F",
                         help="write a car config for `drive` pointing at the emulated ports")
    emulate.add_argument("--summary", type=Path, metavar="F", help="write the summary JSON here")
    emulate.add_argument("--workdir", type=Path, help="folder for the port links (default: temp)")
    emulate.add_argument("--rt-priority", type=int_in(0, 99), default=0, metavar="N",
                         help="SCHED_FIFO priority of the emulator, with its memory locked in RAM "
                              "(default 0: neither); on a busy test machine it keeps the "
                              "stand-in hardware on time")
    emulate.add_argument("--seed", type=non_negative_int,
                         help="random seed of the simulated world (>= 0)")
    emulate.add_argument("--can", choices=("slcan", "udp"), default="slcan",
                         help="the CAN bus: an slcan adapter on a pseudo-terminal (default), or "
                              "python-can's udp_multicast (kernel sockets, as SocketCAN)")
    emulate.add_argument("--serial-stall", type=stall_window, action="append", default=[],
                         metavar="T:D",
                         help="hold the GPS and IMU bytes from T for D seconds of the "
                              "emulator's clock, then write them at once (a stalled serial "
                              "link); repeatable")
    emulate.set_defaults(func=_emulate)

    _register_render(subparsers, common)
    _register_detect(subparsers, common)


def _register_detect(subparsers: Any, common: argparse.ArgumentParser) -> None:
    parser = subparsers.add_parser(
        "detect", parents=[common],
        help="the car's cone detector on recorded point clouds, scored against their labels",
        description="Run the car's LiDAR cone detector on a folder of point clouds "
        "(points/*.bin in the KITTI layout, .npy or .pcd; labels/ scored when present) or on "
        "a pcap capture, a sweep at a time. Writes detections.csv, summary.json, frames/ and "
        "report.html into --out.")
    parser.add_argument("scene", metavar="SCENE", help="scene folder or .pcap capture")
    parser.add_argument("--out", required=True, metavar="DIR", help="output folder")
    parser.add_argument("--lidar", metavar="MODEL", default=None,
                        help="sensor model: vlp16, vlp32c, hdl32e, pandar40p, os1-64 "
                        "(default: sensors.detect.lidar_model, else sensors.lidar.model)")
    parser.add_argument("--meta", metavar="JSON", default=None,
                        help="an Ouster capture's metadata file (beam angles)")
    parser.add_argument("--frames", type=non_negative_int, default=None, metavar="N",
                        help="draw the first N frames to DIR/frames (default: all; 0: none)")
    parser.add_argument("--json", action="store_true", help="print the summary as JSON")
    parser.set_defaults(func=_detect)


def _detect(args: argparse.Namespace, config: AppConfig) -> int:
    from orchestrator.detect import HEADLINE, run_detect

    summary = run_detect(args, config)
    if args.json:
        print(json.dumps(summary))
    else:
        for key in HEADLINE:
            if key in summary:
                print(f"{key:<26} {summary[key]}")
    return 0


def _add_live(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--live", type=host_port, default=None, metavar="[HOST:]PORT",
                        help="serve a live view over a Foxglove WebSocket (host default "
                             "127.0.0.1; same topics as the recording)")


def _sim(args: argparse.Namespace, config: AppConfig) -> int:
    from orchestrator.sim import SimOptions, run_sim
    from orchestrator.summary_table import format_summary

    options = SimOptions(
        track=args.track, laps=args.laps, seed=args.seed, mapper=args.mapper, out_dir=args.out,
        render=args.render, record=args.record, realtime=args.realtime, faults=args.fault,
        progress=sys.stderr.isatty(), mission=args.mission, exploration=args.exploration,
        live=args.live,
    )
    summary = run_sim(config, options)
    if args.json:
        import json

        print(json.dumps(summary, indent=2))
    else:
        print(format_summary(summary))
    if args.profile:
        from orchestrator.budget import format_budget

        timing = summary["timing"]
        print(format_budget(timing["budget"], timing["sim_time_s"], timing["wall_time_s"]),
              file=sys.stderr if args.json else sys.stdout)
    return 0 if summary["stop_reason"] != "timeout" else 1


def _replay(args: argparse.Namespace, config: AppConfig) -> int:
    import json

    from orchestrator.replay import ReplayOptions, run_replay
    from orchestrator.sample import resolve_recording

    config_file = Path(args.config) if args.config else None
    recording = resolve_recording(args.recording)
    summary = run_replay(config, ReplayOptions(recording, rate=args.rate,
                                               out_dir=args.out, render=args.render,
                                               config_file=config_file,
                                               pipeline=not args.single_process,
                                               live=args.live,
                                               progress=sys.stderr.isatty()))
    if args.json:
        print(json.dumps(summary, indent=2))
    elif summary.get("mode") == "localisation":
        print(f"localised {summary['log'] or recording} ({summary['ticks']} ticks, "
              f"{summary['timing']['realtime_factor']}x real time)")
        if "gnss_latency_s" in summary:
            sigma = summary.get("gnss_latency_sigma_s")
            print(f"gnss_latency_s: {summary['gnss_latency_s']}"
                  f"{f' +- {sigma}' if sigma is not None else ''} "
                  f"({summary['gnss_latency_source']})")
        for key in ("position_rmse_m", "heading_rmse_deg", "gnss_raw_rmse_m",
                    "gnss_raw_course_rmse_deg", "nees_position_mean", "gnss_outage"):
            if key in summary:
                print(f"{key}: {summary[key]}")
    else:
        timing = summary["timing"]
        print(f"replayed {summary['ticks']} ticks ({timing['sim_time_s']} s) in "
              f"{timing['wall_time_s']} s, {timing['realtime_factor']}x real time")
        for key in ("pose_rmse_m", "heading_rmse_rad", "final_offset_m"):
            if key in summary:
                print(f"{key}: {summary[key]}")
        print(f"outputs_sha256: {summary['outputs_sha256']}")
    return 0


def _add_mission_options(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--mission", choices=MISSIONS,
                        help="trackdrive (laps; default), autocross (one unseen lap), "
                             "acceleration (the 75 m straight) or skidpad (the figure of eight)")
    parser.add_argument("--exploration", choices=("autonomous", "manual"),
                        help="who drives trackdrive's first lap (default: config "
                             "mission.exploration)")


def _import(args: argparse.Namespace, config: AppConfig) -> int:
    import json

    from orchestrator.log_import import import_log, parse_outage

    outage = parse_outage(args.drop_gnss) if args.drop_gnss is not None else None
    result = import_log(args.format, args.source, args.out, outage)
    if args.json:
        print(json.dumps(result, indent=2))
    else:
        counts = ", ".join(f"{k} {v}" for k, v in sorted(result["counts"].items()))
        print(f"wrote {result['recording']}: {counts} "
              f"({result['end_s'] - result['start_s']:.1f} s of {result['log']})")
    return 0


def _drive(args: argparse.Namespace, config: AppConfig) -> int:
    import json

    from orchestrator.live import DriveOptions, LiveMain
    from orchestrator.sim import default_out_dir

    if args.live is not None:
        from recordings.live_server import check_address

        check_address(*args.live)  # the server starts in the executive process: fail early
    options = DriveOptions(out_dir=args.out or default_out_dir(), laps=args.laps,
                           mission=args.mission, exploration=args.exploration,
                           record=args.record, seconds=args.seconds, render=args.render,
                           live=args.live)
    if args.rt_priority is not None:
        options.realtime_priority = args.rt_priority
    summary = LiveMain(config, options).run()
    print(json.dumps(summary, indent=2))
    return 0


def _record(args: argparse.Namespace, config: AppConfig) -> int:
    import json

    from orchestrator.live import DriveOptions, LiveMain

    out: Path = args.out
    options = DriveOptions(out_dir=out.parent, record=True, control=False, seconds=args.seconds,
                           recording_name=out.name)
    summary = LiveMain(config, options).run()
    print(json.dumps(summary, indent=2))
    return 0


def _emulate(args: argparse.Namespace, config: AppConfig) -> int:
    import json

    from orchestrator.config import apply_mission
    from orchestrator.live import set_realtime_priority
    from orchestrator.priority import lock_memory
    from simulator.emulator import EmulatorOptions, HardwareEmulator

    apply_mission(config.mission, None, args.mission, args.exploration)
    options = EmulatorOptions(track=args.track,
                              exploration_overrun_m=config.run.exploration_overrun_m,
                              handover_standstill_s=config.run.handover_standstill_s,
                              seconds=args.seconds,
                              write_config=args.write_config, summary=args.summary,
                              workdir=args.workdir, seed=args.seed, can=args.can,
                              serial_stalls=tuple(args.serial_stall),
                              mission=config.mission.mission,
                              exploration=config.mission.exploration,
                              ready_wait_s=config.controller.as_state.min_ready_s,
                              move_delay_s=config.controller.as_state.min_driving_before_move_s)
    # before the emulator starts its threads: they inherit the policy
    set_realtime_priority(args.rt_priority, "emulator")
    if args.rt_priority > 0:  # a real-time stand-in for the car: no page read back from disk
        lock_memory("emulator")
    emulator = HardwareEmulator(config, options)
    print(f"emulating {emulator.track.name}: gps {emulator.gps.link_path}, imu "
          f"{emulator.imu.link_path}, can {emulator.can.describe()}, lidar udp "
          f"{emulator.lidar_port}, camera udp {emulator.camera_port}", flush=True)
    summary = emulator.run()
    print(json.dumps(summary, indent=2))
    return 0


def _register_render(subparsers: Any, common: argparse.ArgumentParser) -> None:
    """Add ``render``."""
    parser = subparsers.add_parser("render", parents=[common],
                                   help="draw a recording's map states as PNG frames (and a movie)")
    parser.add_argument("recording", type=Path, help="an .mcap recording")
    parser.add_argument("--out", type=Path, required=True, help="folder for the frames")
    parser.add_argument("--size", type=size_wxh, default=None,
                        help="frame size WxH (default 1280x720)")
    parser.add_argument("--fps", type=positive_float, default=None,
                        help="frames per second of recording time (default: every map state)")
    parser.add_argument("--view", choices=("track", "follow"), default=None,
                        help="whole track, or follow the car")
    parser.add_argument("--movie", type=Path, default=None,
                        help="also write a movie (.mp4 or .gif)")
    parser.set_defaults(func=_render)


def _render(args: argparse.Namespace, config: AppConfig) -> int:
    from orchestrator.render import render_recording

    if args.size is not None:
        config.visualiser.width_px, config.visualiser.height_px = args.size
    if args.view is not None:
        config.visualiser.view = args.view
    try:
        result = render_recording(args.recording, args.out, config.visualiser, fps=args.fps,
                                  movie=args.movie, progress=sys.stderr.isatty())
    except FsdError as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 2
    print(f"{result['frames']} frames in {args.out} ({result['fps']:.1f} frames/s)"
          + (f", movie {result['movie']}" if result.get("movie") else ""))
    return 0
