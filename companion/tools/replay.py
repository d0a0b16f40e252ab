"""``companion replay``: a recorded tlog through the same Pipeline as the live daemon.

Inbound records (everything not sent by a companion component) go through codec.decode and
Pipeline.handle in file order, stamped with their own tlog time, exactly as the daemon fed them
live; so a tlog the daemon recorded replays to the same estimates and the same setpoints. What
the recorded companion sent (its SET_POSITION_TARGET_LOCAL_NED and ODOMETRY) is kept aside and
compared with what the replay would send.

Comparisons are made on the wire values: MAVLink carries float32, so the replayed setpoint is
packed and parsed back, and the replayed pose rounded to float32, before comparing. A
difference of 0 therefore means "bit-identical on the wire"; any real divergence of the
estimator shows up at float32 resolution (about 1e-5 m at 100 m).
"""
from __future__ import annotations

import csv
import math
import time
from collections import Counter
from dataclasses import dataclass, field
from pathlib import Path
from typing import Callable

import numpy as np

from companion.mavlink import codec
from companion.mavlink.tlog import TlogReader, TlogStats
from companion.config.service import CompanionConfig, config_to_dict
from companion.onboard.pipeline import Pipeline, snapshot


@dataclass
class ReplayResult:
    path: Path
    stats: TlogStats
    pipeline: Pipeline
    config: CompanionConfig
    messages: int = 0
    inbound: int = 0
    by_type: Counter = field(default_factory=Counter)
    first_us: int | None = None
    last_us: int | None = None
    wall_s: float = 0.0
    setpoints: list = field(default_factory=list)          # replayed VelocitySetpoint
    replayed_keys: list = field(default_factory=list)      # their wire values
    recorded_keys: list = field(default_factory=list)      # what the companion sent
    replayed_poses: dict = field(default_factory=dict)     # time_usec -> float32 (north, east)
    recorded_poses: list = field(default_factory=list)     # (time_usec, north, east)
    notes: list = field(default_factory=list)


def replay_tlog(path: str | Path, config: CompanionConfig,
                progress: Callable[[int], None] | None = None,
                on_inbound: Callable[[int, Pipeline], None] | None = None) -> ReplayResult:
    """Replay one tlog; never raises on a damaged file (see ``stats`` and ``notes``).
    ``on_inbound(t_us, pipeline)`` after each inbound message (the live view's replay)."""
    reader = TlogReader(path, progress)
    pipeline = Pipeline(config, config.goal, record_track=True)
    result = ReplayResult(Path(path), reader.stats, pipeline, config)
    ours = config.link.component_id
    started = time.perf_counter()
    for record in reader:
        msg = record.msg
        kind = codec.message_type(msg)
        result.messages += 1
        result.by_type[kind] += 1
        result.first_us = record.t_us if result.first_us is None else result.first_us
        result.last_us = record.t_us
        if codec.is_from_us(msg, ours):
            if kind == "SET_POSITION_TARGET_LOCAL_NED":
                result.recorded_keys.append(codec.setpoint_key(msg))
            elif kind == "ODOMETRY":
                result.recorded_poses.append(codec.odometry_key(msg))
            continue
        result.inbound += 1
        for output in pipeline.handle(record.t_us / 1e6, codec.decode(msg)):
            if isinstance(output, codec.VelocitySetpoint):
                result.setpoints.append(output)
                result.replayed_keys.append(codec.setpoint_key_of(output))
            elif isinstance(output, codec.PoseEstimate):
                result.replayed_poses[int(round(output.t_s * 1e6))] = (
                    codec.float32(output.north_m), codec.float32(output.east_m))
        if on_inbound is not None:
            on_inbound(record.t_us, pipeline)
    if len(result.recorded_keys) == len(result.replayed_keys) + 1 and result.last_us is not None:
        # the daemon's shutdown: SIGINT/SIGTERM while commanding sent one stop setpoint
        for output in pipeline.stop_setpoint(result.last_us / 1e6):
            if not isinstance(output, codec.VelocitySetpoint):
                continue                  # PX4's Hold request after it: no setpoint
            result.setpoints.append(output)
            result.replayed_keys.append(codec.setpoint_key_of(output))
    result.wall_s = time.perf_counter() - started
    _add_notes(result)
    return result


def _add_notes(result: ReplayResult) -> None:
    notes, p = result.notes, result.pipeline
    notes.extend(result.stats.notes)
    if result.stats.bytes_skipped:
        notes.append(f"{result.stats.bytes_skipped} corrupt bytes skipped in "
                     f"{result.stats.skipped_regions} place(s)")
    if result.stats.bad_packets:
        notes.append(f"{result.stats.bad_packets} packets unreadable (bad CRC or unknown id)")
    if result.messages and p.vehicle is None:
        notes.append("no autopilot heartbeat found (or not from the --sysid given): nothing replayed")
    if p.other_vehicles:
        notes.append(f"several vehicles: replayed system {p.vehicle[0] if p.vehicle else '?'}, "
                     f"ignored {sorted(p.other_vehicles)} (choose with --sysid)")
    if p.vehicle is not None and not (result.by_type["OBSTACLE_DISTANCE_3D"]
                                      + result.by_type["OBSTACLE_DISTANCE"]):
        notes.append("no obstacle messages: a pose-only track (odometry dead reckoning)")
    if p.vehicle is not None and p.navigator is None:
        notes.append("no LOCAL_POSITION_NED with ATTITUDE from the vehicle: no track")
    if result.config.goal is None:
        notes.append("no goal configured: estimates only, no guidance or setpoints")
    if not result.recorded_keys and not result.recorded_poses:
        notes.append("the tlog holds nothing a companion sent: no comparison")


def comparison(result: ReplayResult) -> dict:
    """Replayed versus recorded: setpoints in order, poses by timestamp (float32 on the wire)."""
    if not result.recorded_keys and not result.recorded_poses:
        return {"setpoints_compared": 0, "setpoints_mismatched": 0, "setpoints_unmatched": 0,
                "poses_compared": 0, "poses_unmatched": 0, "max_position_difference_m": None}
    pairs = list(zip(result.recorded_keys, result.replayed_keys))
    mismatched = sum(1 for rec, rep in pairs if rec != rep)
    differences, unmatched = [], 0
    for t_us, north, east in result.recorded_poses:
        replayed = result.replayed_poses.get(t_us)
        if replayed is None:
            unmatched += 1
            continue
        differences.append(math.hypot(replayed[0] - north, replayed[1] - east))
    return {
        "setpoints_compared": len(pairs),
        "setpoints_mismatched": mismatched,
        "setpoints_unmatched": abs(len(result.recorded_keys) - len(result.replayed_keys)),
        "poses_compared": len(differences),
        "poses_unmatched": unmatched,
        "max_position_difference_m": max(differences) if differences else None,
    }


def report(result: ReplayResult) -> dict:
    duration_s = ((result.last_us - result.first_us) / 1e6) if result.messages else 0.0
    data = {
        "file": str(result.path),
        "messages": result.messages,
        "inbound_messages": result.inbound,
        "messages_by_type": dict(sorted(result.by_type.items())),
        "log_duration_s": duration_s,
        "wall_s": result.wall_s,
        "messages_per_s": result.messages / result.wall_s if result.wall_s > 0 else None,
        "notes": result.notes,
        "tlog": {"bytes": result.stats.bytes_total, "records": result.stats.records,
                 "bytes_skipped": result.stats.bytes_skipped,
                 "bad_packets": result.stats.bad_packets,
                 "truncated_tail_bytes": result.stats.truncated_tail_bytes},
        **comparison(result),
        **snapshot(result.pipeline),
        "setpoints": [{"t_s": s.t_s, "vel_north_mps": s.vel_north_mps,
                       "vel_east_mps": s.vel_east_mps, "yaw_rad": s.yaw_rad, "reason": s.reason}
                      for s in result.setpoints],
        "config": config_to_dict(result.config),
    }
    return data


def write_track_csv(path: str | Path, result: ReplayResult) -> None:
    """The estimated track: one row per odometry sample, variances from the pose covariance."""
    with open(path, "w", newline="") as out:
        writer = csv.writer(out)
        writer.writerow(["t_s", "north_m", "east_m", "yaw_rad", "var_north_m2", "var_east_m2",
                         "var_yaw_rad2"])
        for row in result.pipeline.track:
            t_s, north, east, yaw, *cov = row
            writer.writerow([f"{t_s:.3f}", f"{north:.6f}", f"{east:.6f}", f"{yaw:.6f}",
                             f"{cov[0]:.6g}", f"{cov[4]:.6g}", f"{cov[8]:.6g}"])


def plot_replay(path: str | Path, result: ReplayResult) -> None:
    from companion.sim.plot import plot_paths
    p = result.pipeline
    track = np.array([row[1:3] for row in p.track]).reshape(-1, 2)
    nav = p.navigator
    landmarks = nav.slam.landmarks() if nav else np.zeros((0, 2))
    covs = nav.slam.landmark_covs() if nav else np.zeros((0, 2, 2))
    goal_ne = np.array(p.goal_ne) if p.goal_ne is not None else (
        track[-1] if len(track) else np.zeros(2))
    plot_paths(path, true_ne=np.zeros((0, 2)), est_ne=track, obstacles_ne=np.zeros((0, 2)),
               obstacle_radii=np.zeros(0),
               safety_distance_m=result.config.safety_distance_m, goal_ne=goal_ne,
               landmarks_ne=landmarks, landmark_covs=covs,
               title=f"replay of {result.path.name}",
               start_ne=track[0] if len(track) else None)
