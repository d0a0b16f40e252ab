"""Component 100, the stereo camera: its heartbeat and its unasked obstacle reports."""
from __future__ import annotations

from . import telemetry as tm
from .camera import Detection
from .sim import Simulation

HEARTBEAT_INTERVAL_S = 1.0


class CameraComponent:
    """Publishes OBSTACLE_DISTANCE_3D (and optionally OBSTACLE_DISTANCE) at sensor.rate_hz; a
    frame with no detection is an OBSTACLE_DISTANCE with every sector empty.

    Frames are captured on physics steps: the first step at or after each nominal frame time.
    All reports of one frame share that step's time_boot_ms. Reporting does not depend on
    arming or mode. In a 3D world (world.py) each detection is two points, its highest and its
    lowest seen (telemetry.obstacle_points_3d), and a floor-seeing camera adds its floor
    returns, id-less, after them.
    """

    def __init__(self, sim: Simulation) -> None:
        self.sim = sim
        self.cfg = sim.scenario.sensor
        self._frame_interval_s = 1.0 / self.cfg.rate_hz
        self._next_frame_s = 0.0
        self._next_heartbeat_s = 0.0
        self.frames = 0
        self.last_frame: list[Detection] = []

    def periodic(self, t_s: float) -> list[tuple[int, object]]:
        out: list[tuple[int, object]] = []
        if t_s + 1e-9 >= self._next_heartbeat_s:
            out.append((tm.COMP_CAMERA, tm.heartbeat_camera()))
            self._next_heartbeat_s = _advance(self._next_heartbeat_s, HEARTBEAT_INTERVAL_S, t_s)
        if t_s + 1e-9 >= self._next_frame_s and self.cfg.form != "depth":
            # (form depth: the camera's frames go out on the depth stream, depth_stream.py)
            form = self.cfg.form
            detections = self.sim.observe() if form != "sectors" else []
            floor = self.sim.ground_points() if form != "sectors" else []
            self.frames += 1
            self.last_frame = detections
            for det in detections:
                out.extend((tm.COMP_CAMERA, msg) for msg in tm.obstacle_points_3d(det, t_s, self.cfg))
            for point in floor:
                out.append((tm.COMP_CAMERA, tm.ground_point_3d(point, t_s, self.cfg)))
            if form in ("sectors", "both"):
                # a depth camera: its own ray-cast sectors every frame (sensor.form)
                out.append((tm.COMP_CAMERA, tm.obstacle_distance(
                    [], t_s, self.cfg, self.sim.scan_sectors())))
            elif self.cfg.sector_message or not (detections or floor):
                # Nothing seen is still a frame: an OBSTACLE_DISTANCE with every sector at
                # max_distance + 1, as depth cameras send it, so the receiver knows the camera
                # is live (its heartbeat alone says nothing about its data).
                out.append((tm.COMP_CAMERA, tm.obstacle_distance(detections, t_s, self.cfg)))
            self._next_frame_s = _advance(self._next_frame_s, self._frame_interval_s, t_s)
        return out


def _advance(next_s: float, interval_s: float, t_s: float) -> float:
    next_s += interval_s
    return next_s if next_s > t_s else t_s + interval_s
