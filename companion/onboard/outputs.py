"""What the pipeline hands back besides MAVLink intents, and the estimate it publishes.

The events for the service (:class:`StreamsWanted`, :class:`NavigatorStarted`, :class:`Arrived`),
the urgency records of the report, and :class:`EstimateOutputs`: after each odometry sample the
track row (for the report), the obstacle map as OBSTACLE_DISTANCE sectors (map_output.py), our
ODOMETRY at ``commanding.odometry_rate_hz`` and the tracked movers with it; and ``snapshot``,
a pipeline's results as plain data (the report, replay, the tests).
"""
from __future__ import annotations

from array import array
from collections import deque
from dataclasses import asdict, dataclass

import numpy as np

from companion.mavlink import codec, mission_codec
from companion.onboard import odometry_intake
from companion.onboard.map_output import TIME_EPS_S, MapPublisher
from companion.onboard.parameters import ParamChange, ParamValue


@dataclass(frozen=True)
class StreamsWanted:
    """Ask the vehicle for its telemetry streams (again)."""
    reason: str


@dataclass(frozen=True)
class NavigatorStarted:
    t_s: float


@dataclass(frozen=True)
class Arrived:
    t_s: float


Output = codec.VelocitySetpoint | codec.PoseEstimate | codec.Notice | codec.MoverReport \
    | codec.ModeRequest \
    | codec.SectorMap | mission_codec.MissionRequest | StreamsWanted \
    | NavigatorStarted | Arrived | ParamValue | ParamChange


@dataclass(frozen=True)
class UrgencyRecord:
    t_s: float
    state: str                      # 'urgent' or 'cleared'
    obstacle_id: int | None
    landmark_index: int | None
    time_to_go_s: float | None


class EstimateOutputs:
    """The track kept for the report, and the map, pose and movers sent after each sample."""

    def __init__(self, map_out_config, record_track: bool, track_limit: int | None) -> None:
        self.record_track = record_track
        # rows (t_s, north_m, east_m, yaw_rad, 9 cov) as compact float arrays (104 bytes each)
        self.track: deque[array] = deque(maxlen=track_limit)
        self.map_out = MapPublisher(map_out_config)
        self._last_pose_out_t_s: float | None = None

    def reset(self) -> None:
        """The estimate restarted: the next sample's pose goes out at once."""
        self._last_pose_out_t_s = None

    def record(self, t_s: float, navigator) -> None:
        """The sample's pose and covariance into the track (when one is kept)."""
        if self.record_track:
            pose, cov = navigator.slam.pose, navigator.slam.pose_cov
            self.track.append(array("d", (t_s, *pose.tolist(), *cov.ravel().tolist())))

    def publish(self, t_s: float, navigator, odometry_rate_hz: float, reset_counter: int,
                out: list) -> None:
        """After the sample's decision: the map's sectors when due, then our pose and movers."""
        scan = self.map_out.scan(t_s, navigator.slam.pose, navigator.slam.landmarks())
        if scan is not None:
            out.append(scan)
        self._publish_pose(t_s, navigator, odometry_rate_hz, reset_counter, out)

    def _publish_pose(self, t_s: float, navigator, odometry_rate_hz: float, reset_counter: int,
                      out: list) -> None:
        if self._last_pose_out_t_s is not None and t_s - self._last_pose_out_t_s \
                < 1.0 / odometry_rate_hz - TIME_EPS_S:
            return
        slam = navigator.slam
        pose, cov = slam.pose, slam.pose_cov
        if not (np.all(np.isfinite(pose)) and np.all(np.isfinite(cov))):
            return
        self._last_pose_out_t_s = t_s
        north_m, east_m, yaw_rad = pose.tolist()
        out.append(codec.PoseEstimate(t_s, north_m, east_m, yaw_rad,
                                      tuple(map(tuple, cov.tolist())), reset_counter,
                                      odometry_intake.quality(navigator)))
        # Tracked movers, for the ground station to see (docs/messages.md).
        for mover in navigator.movers.states(navigator.clock_s):
            if np.all(np.isfinite(mover.position_ne_m)):
                out.append(codec.MoverReport(t_s, mover.obstacle_id, mover.track_id,
                                             float(mover.position_ne_m[0]),
                                             float(mover.position_ne_m[1])))


def snapshot(pipeline) -> dict:
    """The pipeline's results as plain data: track, map, urgency events, arrival, counters."""
    nav = pipeline.navigator
    landmarks = []
    if nav is not None:
        for oid, mean, cov in zip(nav.slam.landmark_ids(), nav.slam.landmarks(),
                                  nav.slam.landmark_covs()):
            landmarks.append({"id": oid if oid is None or oid >= 0 else None,  # < 0: internal
                              "north_m": float(mean[0]), "east_m": float(mean[1]),
                              "cov_m2": cov.tolist()})
    columns = ("t_s", "north_m", "east_m", "yaw_rad")
    track = {name: [row[i] for row in pipeline.track] for i, name in enumerate(columns)}
    track["pose_cov"] = [list(row[4:]) for row in pipeline.track]
    return {
        "vehicle": list(pipeline.vehicle) if pipeline.vehicle else None,
        "other_vehicles": sorted(pipeline.other_vehicles),
        "goal": asdict(pipeline.goal) if pipeline.goal is not None else None,
        "goal_ne_m": list(pipeline.goal_ne) if pipeline.goal_ne is not None else None,
        "started_t_s": pipeline.started_t_s,
        "arrived": pipeline.arrival_t_s is not None,
        "arrival_t_s": pipeline.arrival_t_s,
        "reset_counter": pipeline.reset_counter,
        "position_resets": list(pipeline.position_resets),
        "setpoints": pipeline.setpoints,
        "track": track,
        "landmarks": landmarks,
        "urgency_events": [asdict(r) for r in pipeline.urgency],
        "counters": dict(pipeline.counters),
        "rejected_by_estimator": dict(nav.rejected) if nav is not None else {},
        "mission": pipeline.mission.summary() if pipeline.mission is not None else None,
        "parameters": pipeline.params.summary(),
        **odometry_intake.snapshot(nav),
        **pipeline.heights.snapshot(nav),
        **pipeline.depth.snapshot(),        # only with a depth source: other reports unchanged
        # PX4 only (onboard/autopilot_dialect.py): ArduPilot flights' reports unchanged
        **({"offboard": {"entry": o.params.entry, "requests": o.requests,
                         "seen_offboard": o.seen_offboard, "engaged_by_us": o.engaged_by_us,
                         "gave_up": o.gave_up}}
           if pipeline.identity.dialect.name == "px4" and (o := pipeline.offboard) else {}),
        # only after a start in the air (onboard/look_around.py): other flights' reports unchanged
        **({"look_around": {"started_t_s": look.started_t_s, "ended_t_s": look.ended_t_s,
                            "end_reason": look.end_reason, "backed_off_from_m": look.backed_off_m}}
           if (look := pipeline.look_around).started_t_s is not None else {}),
    }
