"""The estimate-and-guide pipeline shared by ``simulate``, the live service and ``replay``.

Pure: odometry and observations go in with their times, guidance commands come out. Whoever feeds
it (the in-process truth world, MAVLink, a tlog) cannot be told apart from here.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from companion.core.ekf_slam import AssociationGates, EkfSlam, Observation, SlamNoise, UpdateReport
from companion.core.guidance import GuidanceCommand, GuidanceParams, guide_apf, guide_cone


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
                 strategy: str = "cone") -> None:
        if strategy not in ("cone", "apf"):
            raise ValueError(f"unknown strategy {strategy!r}")
        self.slam = EkfSlam(start_pose, start_pose_cov, noise, gates)
        self.params = params
        self.goal = np.asarray(goal, dtype=float)
        self.strategy = strategy
        self._urgent: int | None = None

    def predict(self, speed_mps: float, heading_change_rad: float, dt_s: float) -> None:
        self.slam.predict(speed_mps, heading_change_rad, dt_s)

    def observe(self, observations: list[Observation]) -> list[UpdateReport]:
        return self.slam.update_frame(observations)

    def decide(self, t_s: float) -> tuple[GuidanceCommand, UrgencyChange | None]:
        """Guidance on the current estimate, and the urgency change it implies, if any."""
        slam = self.slam
        pose = slam.pose
        landmarks = slam.landmarks()
        if self.strategy == "apf":
            command = guide_apf(pose, self.goal, landmarks, self.params)
        else:
            rel_covs = slam.relative_covs() if self.params.inflation_sigmas > 0 else None
            command = guide_cone(pose, self.goal, landmarks, rel_covs, self.params, t_s)
        change = None
        if command.urgent_index != self._urgent:
            self._urgent = command.urgent_index
            oid = None if command.urgent_index is None else slam.landmark_ids()[command.urgent_index]
            change = UrgencyChange(t_s, command.urgent_index, oid, command.time_to_go_s)
        return command, change
