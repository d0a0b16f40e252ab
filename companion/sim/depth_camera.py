"""companion simulate's depth cameras (``sensor.form: depth``): the world as a depth scene, the
vehicle's tilt, and the frames due since the last step, rendered from the TRUE pose.

A multicopter tilts its thrust to accelerate: accelerating at a (NED, m/s^2) its body z axis
points along (-a_n, -a_e, g - a_d) normalised, so with its yaw it pitches nose-down by
atan(a_forward / g) and rolls right by asin(a_right / |thrust|) (``tilt_from_accel``). The truth
steps at vehicle.dt_s; frames are due at the camera's own rate (k / rate_hz), each from the pose
interpolated at its time and the tilt of the step it falls in.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from companion.config.scenario import Scenario
from companion.config.world import World
from companion.core.perception.depth_frame import CameraMount, DepthFrame, rotation_zyx
from companion.core.geometry import wrap_angle
from companion.sim.depth_render import DepthRenderer, DepthScene, ErrorModel, Prism, StereoErrors

GRAVITY_MPS2 = 9.80665


def depth_sensor_record(sensor) -> dict:
    """The depth camera of a scenario's sensor section for a JSON report: form, intrinsics (the
    image, focal lengths, principal point, depth span and unit), rate, errors, each mount."""
    intr = sensor.depth.intrinsics()
    depth = sensor.depth
    return {"form": sensor.form, "rate_hz": depth.rate_hz,
            "intrinsics": {k: getattr(intr, k) for k in (
                "width_px", "height_px", "fx_px", "fy_px", "cx_px", "cy_px", "min_depth_m",
                "max_depth_m", "depth_scale_m")},
            "errors": {k: getattr(depth, k) for k in (
                "baseline_m", "subpixel", "depth_noise", "noise_patch_px", "edge_shadow",
                "shadow_band_px", "dropout_fraction")},
            "cameras": [{"camera_id": i, "offset_frd_m": list(m.offset_frd_m),
                         "roll_deg": math.degrees(m.roll_rad),
                         "pitch_deg": math.degrees(m.pitch_rad),
                         "yaw_deg": math.degrees(m.yaw_rad)}
                        for i, m in enumerate(sensor.camera_mounts())]}


def tilt_from_accel(accel_ned_mps2, yaw_rad: float) -> tuple[float, float]:
    """(roll_rad, pitch_rad) of a multicopter whose thrust gives the acceleration at this yaw."""
    a_n, a_e, a_d = (float(v) for v in accel_ned_mps2)
    forward = a_n * math.cos(yaw_rad) + a_e * math.sin(yaw_rad)
    right = -a_n * math.sin(yaw_rad) + a_e * math.cos(yaw_rad)
    up = GRAVITY_MPS2 - a_d
    thrust = math.sqrt(forward * forward + right * right + up * up)
    return math.asin(right / thrust), math.atan2(-forward, up)


def scene_of(world: World, t_s: float) -> DepthScene:
    """The world at ``t_s``: its obstacles (movers where they are then) as posts, its walls and
    buildings as prisms."""
    obstacles = world.obstacles
    ne = np.array([[o.north_m + o.vel_north_mps * t_s, o.east_m + o.vel_east_mps * t_s]
                   for o in obstacles]).reshape(-1, 2)
    return DepthScene(ne, np.array([o.radius_m for o in obstacles]),
                      np.array([o.base_m for o in obstacles]),
                      np.array([math.inf if o.height_m is None else o.height_m for o in obstacles]),
                      tuple(Prism(shape.corners_ne(), shape.base_m,
                                  math.inf if shape.height_m is None else shape.height_m)
                            for _, shape in world.shapes()))


@dataclass(frozen=True)
class TruePose:
    """A vehicle's true pose: north, east (m), altitude above the ground (m), roll, pitch and
    yaw (rad, ZYX: body FRD into NED)."""
    north_m: float
    east_m: float
    alt_m: float
    roll_rad: float = 0.0
    pitch_rad: float = 0.0
    yaw_rad: float = 0.0


def camera_pose(pose: TruePose, mount: CameraMount) -> tuple[np.ndarray, np.ndarray]:
    """(world_from_optical 3x3, camera origin NED (3,)) of a camera on a vehicle."""
    body = rotation_zyx(pose.roll_rad, pose.pitch_rad, pose.yaw_rad)
    origin = np.array([pose.north_m, pose.east_m, -pose.alt_m]) + body @ np.array(mount.offset_frd_m)
    return body @ mount.frd_from_optical(), origin


def render_true_m(renderer: DepthRenderer, scene: DepthScene, pose: TruePose,
                  mount: CameraMount, out: np.ndarray | None = None) -> np.ndarray:
    """(H, W) true depth, metres (inf: nothing), of one camera (into ``out`` if given)."""
    rotation, origin = camera_pose(pose, mount)
    return renderer.render_m(rotation, origin, scene, out)


class SimDepthCamera:
    """The rig of ``sensor.cameras`` (one camera when none is given), its frame clock and its
    random source. ``frames_due(truth)`` after every truth step (and once before the first)."""

    def __init__(self, scenario: Scenario, rng: np.random.Generator) -> None:
        sensor = scenario.sensor
        self.world = scenario.world
        self.intrinsics = sensor.depth.intrinsics()
        self.mounts = sensor.camera_mounts()
        self.errors = StereoErrors.of(sensor.depth)
        self.renderer = DepthRenderer(self.intrinsics)
        self.error_model = ErrorModel(self.intrinsics, self.errors)
        self._true_m = np.empty((self.intrinsics.height_px, self.intrinsics.width_px))
        self.period_s = 1.0 / sensor.depth.rate_hz
        self.rng = rng
        self.next_frame = 0
        self._last: tuple | None = None      # (t_s, (n, e, alt), yaw, velocity NED)
        self.last_pose: TruePose | None = None

    def frames_due(self, truth) -> list[DepthFrame]:
        """Every frame of every camera due in (previous call's time, truth.t_s]."""
        t_s = truth.t_s
        yaw = float(truth.pose[2])
        speed = truth.speed_mps
        vel_ne = truth.vel_ne_mps if truth.scenario.vehicle.kind == "multicopter" \
            else speed * np.array([math.cos(yaw), math.sin(yaw)])
        vel = np.array([vel_ne[0], vel_ne[1], -truth.vel_up_mps])
        now = (t_s, np.array([truth.pose[0], truth.pose[1], truth.altitude_m]), yaw, vel)
        last = self._last if self._last is not None else now
        self._last = now
        dt = now[0] - last[0]
        accel = (now[3] - last[3]) / dt if dt > 0.0 else np.zeros(3)
        frames = []
        while self.next_frame * self.period_s <= t_s + 1e-9:
            t_frame = self.next_frame * self.period_s
            w = 1.0 if dt <= 0.0 else min(1.0, max(0.0, (t_frame - last[0]) / dt))
            pos = last[1] + w * (now[1] - last[1])
            yaw_f = wrap_angle(last[2] + w * wrap_angle(now[2] - last[2]))
            roll, pitch = tilt_from_accel(accel, yaw_f)
            pose = TruePose(float(pos[0]), float(pos[1]), float(pos[2]), roll, pitch, yaw_f)
            self.last_pose = pose
            frames += self.render(pose, t_frame, self.next_frame)
            self.next_frame += 1
        return frames

    def render(self, pose: TruePose, t_s: float, frame_number: int) -> list[DepthFrame]:
        """One frame of every camera from ``pose`` at ``t_s`` (with the configured errors)."""
        scene = scene_of(self.world, t_s)
        out = []
        for camera_id, mount in enumerate(self.mounts):
            true_m = render_true_m(self.renderer, scene, pose, mount, self._true_m)
            pixels = self.error_model(true_m, self.rng)
            out.append(DepthFrame(frame_number, int(round(t_s * 1000.0)), camera_id,
                                  self.intrinsics, pixels))
        return out
