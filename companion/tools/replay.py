"""``companion replay``'s comparison and report: what a tlog replayed through the daemon's
Pipeline (companion/daemon/replay.py) sends, against what the recorded companion sent.

Comparisons are made on the wire values: MAVLink carries float32, so the replayed setpoint is
packed and parsed back, and the replayed pose rounded to float32, before comparing. A
difference of 0 therefore means "bit-identical on the wire"; any real divergence of the
estimator shows up at float32 resolution (about 1e-5 m at 100 m).
"""
from __future__ import annotations

import csv
import math
from pathlib import Path

import numpy as np

from companion.config.service import config_to_dict
from companion.onboard.pipeline import snapshot
# the replay itself is the daemon's wiring fed from a file; this module compares and reports it
from companion.daemon.replay import ReplayResult, replay_tlog  # noqa: F401  (re-exported)


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
