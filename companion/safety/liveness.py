"""Is the vehicle's heartbeat fresh (link time)? Is the camera's obstacle data stale (vehicle time)?"""
from __future__ import annotations


class Liveness:
    def __init__(self, heartbeat_timeout_s: float, camera_timeout_s: float,
                 require_camera: bool) -> None:
        self.heartbeat_timeout_s = heartbeat_timeout_s
        self.camera_timeout_s = camera_timeout_s
        self.require_camera = require_camera
        self.heartbeat_link_s: float | None = None
        self.last_camera_t_s: float | None = None
        self._camera_alive_unstamped = False

    # ------------------------------------------------------------ vehicle heartbeat
    def on_vehicle_heartbeat(self, t_link_s: float) -> None:
        self.heartbeat_link_s = t_link_s

    def heartbeat_fresh(self, t_link_s: float) -> bool:
        return (self.heartbeat_link_s is not None
                and t_link_s - self.heartbeat_link_s <= self.heartbeat_timeout_s)

    # ------------------------------------------------------------ camera
    def on_camera_heartbeat(self, latest_t_s: float | None) -> None:
        """The camera's heartbeat has no time of its own: stamp it with the vehicle's latest."""
        self._camera_alive_unstamped = latest_t_s is None
        if latest_t_s is not None:
            self.last_camera_t_s = latest_t_s

    def on_vehicle_time(self, t_s: float) -> None:
        if self._camera_alive_unstamped:
            self._camera_alive_unstamped = False
            self.last_camera_t_s = t_s

    def on_camera_frame(self, t_s: float) -> None:
        self.last_camera_t_s = t_s

    def forget_camera(self) -> None:
        self.last_camera_t_s = None

    def camera_stale(self, t_s: float) -> bool:
        if self.last_camera_t_s is None:
            return self.require_camera
        return t_s - self.last_camera_t_s > self.camera_timeout_s
