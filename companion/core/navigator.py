"""The estimate-and-guide pipeline shared by ``simulate``, the live service and ``replay``.

Pure: odometry and observations go in with their times, guidance commands come out. Whoever feeds
it (the in-process truth world, MAVLink, a tlog) cannot be told apart from here.
"""
from __future__ import annotations

import math
from collections import deque
from dataclasses import dataclass

import numpy as np

from companion.core.ekf_slam import AssociationGates, EkfSlam, Observation, SlamNoise, UpdateReport
from companion.core.geometry import wrap_angle
from companion.core.guidance import GuidanceCommand, GuidanceParams, guide_apf, guide_cone
from companion.core.union import UnionParams, guide_union

# An observation frame stamped at most this much after the last odometry is processed at once
# (the pose is that close); a later one waits for the odometry that covers its time.
STRATEGIES = ("cone", "union", "apf")
SAME_TIME_TOLERANCE_S = 1e-3
MAX_PENDING_FRAMES = 8


@dataclass(frozen=True)
class UrgencyChange:
    """Emitted when the most urgent obstacle changes: became urgent (index) or cleared (None)."""
    t_s: float
    landmark_index: int | None
    obstacle_id: int | None
    time_to_go_s: float | None


class Navigator:
    """EKF-SLAM plus guidance. ``strategy``: 'cone' (the paper) or 'apf' (Khatib)."""

    def __init__(self, start_pose: np.ndarray, start_pose_cov: np.ndarray, noise: SlamNoise,
                 gates: AssociationGates, params: GuidanceParams, goal: np.ndarray,
                 strategy: str = "cone", union: UnionParams = UnionParams()) -> None:
        if strategy not in STRATEGIES:
            raise ValueError(f"unknown strategy {strategy!r}")
        self.slam = EkfSlam(start_pose, start_pose_cov, noise, gates)
        self.params = params
        self.goal = np.asarray(goal, dtype=float)
        self.strategy = strategy
        self.union = union
        self._last_heading: float | None = None
        self._side = 0
        self._urgent: int | None = None
        self.t_s: float | None = None          # time of the last odometry the filter has absorbed
        self._yaw_rad: float | None = None
        self._pending: deque[tuple[float, list[Observation]]] = deque()
        self.rejected: dict[str, int] = {}

    # ------------------------------------------------------ timed inputs
    # The live service and the replay feed messages through these two methods, stamped with the
    # messages' own clock (time_boot_ms), so the same stream gives the same estimates anywhere.
    def on_odometry(self, t_s: float, speed_mps: float, yaw_rad: float) -> list[UpdateReport]:
        """Absorb one odometry sample: the speed over the interval ending at ``t_s`` and the
        autopilot's (gyro-integrated) yaw at ``t_s``. The heading change is the yaw difference, so
        a lost sample costs no heading. Then process any observation frames this time covers.
        """
        if not (math.isfinite(t_s) and math.isfinite(speed_mps) and math.isfinite(yaw_rad)) \
                or speed_mps < 0.0:
            self._reject("odometry_not_finite")
            return []
        if self.t_s is None:
            self.t_s, self._yaw_rad = t_s, yaw_rad
            return self._release()
        dt = t_s - self.t_s
        if dt <= 0.0:
            self._reject("odometry_not_newer")
            return []
        self.predict(speed_mps, wrap_angle(yaw_rad - self._yaw_rad), dt)
        self.t_s, self._yaw_rad = t_s, yaw_rad
        return self._release()

    def on_observations(self, t_s: float, observations: list[Observation]) -> list[UpdateReport]:
        """One camera frame captured at ``t_s``; waits if the odometry has not reached ``t_s``."""
        if self.t_s is not None and t_s <= self.t_s + SAME_TIME_TOLERANCE_S:
            return self.observe(observations)
        if len(self._pending) >= MAX_PENDING_FRAMES:
            self._pending.popleft()
            self._reject("frame_overflow")
        self._pending.append((t_s, observations))
        return []

    def _release(self) -> list[UpdateReport]:
        reports: list[UpdateReport] = []
        while self._pending and self._pending[0][0] <= self.t_s + SAME_TIME_TOLERANCE_S:
            reports.extend(self.observe(self._pending.popleft()[1]))
        return reports

    def _reject(self, kind: str) -> None:
        self.rejected[kind] = self.rejected.get(kind, 0) + 1

    def predict(self, speed_mps: float, heading_change_rad: float, dt_s: float) -> None:
        self.slam.predict(speed_mps, heading_change_rad, dt_s)

    def observe(self, observations: list[Observation]) -> list[UpdateReport]:
        return self.slam.update_frame(observations)

    def decide(self, t_s: float) -> tuple[GuidanceCommand, UrgencyChange | None]:
        """Guidance on the current estimate, and the urgency change it implies, if any."""
        slam = self.slam
        pose = slam.pose
        landmarks = slam.landmarks()
        rel_covs = slam.relative_covs() if self.params.inflation_sigmas > 0 else None
        if self.strategy == "apf":
            command = guide_apf(pose, self.goal, landmarks, self.params)
        elif self.strategy == "union":
            command = guide_union(pose, self.goal, landmarks, rel_covs, self.params, self.union,
                                  self._last_heading, self._side)
            self._side = command.side
        else:
            command = guide_cone(pose, self.goal, landmarks, rel_covs, self.params, t_s)
        self._last_heading = command.heading_rad
        change = None
        if command.urgent_index != self._urgent:
            self._urgent = command.urgent_index
            oid = None if command.urgent_index is None else slam.landmark_ids()[command.urgent_index]
            change = UrgencyChange(t_s, command.urgent_index, oid, command.time_to_go_s)
        return command, change
