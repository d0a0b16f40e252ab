"""Is the vehicle's heartbeat fresh (link time)? Is the camera's obstacle data stale (vehicle time)?

The camera is live while its obstacle messages arrive: an empty frame (OBSTACLE_DISTANCE with
every sector "nothing seen") counts, its heartbeat does not (a camera that only heartbeats
delivers no obstacle data). A frame counts at its own time, but never later than the vehicle's
latest time: a frame stamped in the future cannot keep the camera "live" beyond what the
vehicle's own clock has reached.
"""
from __future__ import annotations


class Liveness:
    def __init__(self, heartbeat_timeout_s: float, camera_timeout_s: float,
                 require_camera: bool) -> None:
        self.heartbeat_timeout_s = heartbeat_timeout_s
        self.camera_timeout_s = camera_timeout_s
        self.require_camera = require_camera
        self.heartbeat_link_s: float | None = None
        self.last_camera_t_s: float | None = None

    # ------------------------------------------------------------ vehicle heartbeat
    def on_vehicle_heartbeat(self, t_link_s: float) -> None:
        self.heartbeat_link_s = t_link_s

    def heartbeat_fresh(self, t_link_s: float) -> bool:
        return (self.heartbeat_link_s is not None
                and t_link_s - self.heartbeat_link_s <= self.heartbeat_timeout_s)

    # ------------------------------------------------------------ camera
    def on_camera_frame(self, t_s: float, vehicle_now_s: float | None) -> None:
        """An obstacle message (empty or not) the clock accepted, at vehicle time ``t_s``."""
        if vehicle_now_s is not None:
            t_s = min(t_s, vehicle_now_s)
        if self.last_camera_t_s is None or t_s > self.last_camera_t_s:
            self.last_camera_t_s = t_s

    def forget_camera(self) -> None:
        self.last_camera_t_s = None

    def camera_stale(self, t_s: float) -> bool:
        """No obstacle message for ``camera_timeout_s`` of vehicle time (or none yet and the
        camera is required)."""
        if self.last_camera_t_s is None:
            return self.require_camera
        return t_s - self.last_camera_t_s > self.camera_timeout_s
