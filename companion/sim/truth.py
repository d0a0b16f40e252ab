"""The in-process truth world of ``companion simulate``: the vehicle and the camera, with noise.

Two vehicles: the paper's unicycle (``step``: it flies along its yaw) and a multicopter
(``step_copter``: a velocity command with an independent yaw, as ArduCopter's GUIDED).

Only the simulation uses this; the estimator sees what it returns (noisy odometry and noisy
observations), never the state. It has its own random source, seeded per run.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from companion.config.scenario import Scenario
from companion.core.estimation.slam_types import Observation
from companion.core import shapes
from companion.core.geometry import is_visible, move, wrap_angle

FALSE_ALARM_MIN_RANGE_M = 0.5
Z_SIGMA_FLOOR_M = 0.05         # a point's height error at no range (a choice)


@dataclass(frozen=True)
class Odometry:
    """What the autopilot reports for one step: speed and heading change, both noisy."""
    speed_mps: float
    heading_change_rad: float


@dataclass(frozen=True)
class CopterOdometry:
    """What a multicopter's autopilot reports for one step, all noisy: the NED velocity, the yaw
    rate over the step, the AHRS yaw, and the horizontal position with a GPS's error."""
    vel_north_mps: float
    vel_east_mps: float
    yaw_rate_rad_s: float
    yaw_rad: float
    position_ne_m: tuple[float, float]


@dataclass(frozen=True)
class Clearance:
    """``clearance_m``: to a circle's centre (the paper's figure, comparable with d), to a wall's
    or building's surface. ``surface_m``: to the nearest surface of anything (a circle's centre
    distance minus its radius). Negative ``surface_m``: inside, a collision."""
    clearance_m: float
    surface_m: float


def gauss_markov_step(value, sigma: float, tau_s: float, dt_s: float, rng: np.random.Generator,
                      size: int | None = None):
    """One ``dt_s`` step of a first-order Gauss-Markov process of stationary ``sigma`` and
    correlation time ``tau_s`` (a GPS's or an AHRS's slow bias): one normal draw of ``size``."""
    keep = math.exp(-dt_s / tau_s)
    return keep * value + rng.normal(0.0, sigma * math.sqrt(1.0 - keep * keep), size)


class TruthWorld:
    """The vehicle's true pose and speed, the obstacles' true positions, and the sensors."""

    def __init__(self, scenario: Scenario, rng: np.random.Generator,
                 vertical_rng: np.random.Generator | None = None,
                 depth_rng: np.random.Generator | None = None, depth_sink=None) -> None:
        self.scenario = scenario
        # sensor.form depth: the rendered cameras (sim/depth_camera.py), their own random source;
        # depth_sink(frames) sees every frame (companion depth-record)
        self.depth_camera = None
        if scenario.sensor.form == "depth":
            from companion.sim.depth_camera import SimDepthCamera
            self.depth_camera = SimDepthCamera(
                scenario, depth_rng if depth_rng is not None else np.random.default_rng(0))
        self.depth_sink = depth_sink
        self.rng = rng
        # the centres form's rig: each camera's yaw on the body (one forward camera: (0.0,))
        self.view_yaws_rad = tuple(math.radians(v) for v in scenario.sensor.view_yaws_deg)
        # heights have their own random source (the points' z, the altitude's noise, the floor's
        # returns), so a world without heights keeps its random stream as before
        self.vertical_rng = vertical_rng if vertical_rng is not None else np.random.default_rng(0)
        start = scenario.world.start
        self.altitude_m = start.alt_m
        self.vel_up_mps = 0.0
        self.pose = np.array([start.north_m, start.east_m, wrap_angle(start.yaw_rad)])
        # the paper starts already cruising; vehicle.start_at_rest: from a hover
        self.speed_mps = 0.0 if scenario.vehicle.start_at_rest else scenario.vehicle.speed_mps
        self.t_s = 0.0
        obstacles = scenario.world.obstacles
        self._obstacle_start = np.array([[o.north_m, o.east_m] for o in obstacles]).reshape(-1, 2)
        self._obstacle_vel = np.array([[o.vel_north_mps, o.vel_east_mps]
                                       for o in obstacles]).reshape(-1, 2)
        self.obstacle_radii = np.array([o.radius_m for o in obstacles])
        self.obstacle_ids = [o.id for o in obstacles]
        self.obstacle_tops_m = np.array([math.inf if o.height_m is None else o.height_m
                                         for o in obstacles])
        self.obstacle_bases_m = np.array([o.base_m for o in obstacles])
        self.shape_extents_m = [(shape.base_m, math.inf if shape.height_m is None
                                 else shape.height_m) for _, shape in scenario.world.shapes()]
        # walls and buildings: static convex polygons (core/shapes.py), seen by sectors only
        self.shape_ids = [shape.id for _, shape in scenario.world.shapes()]
        self.shape_corners = [shape.corners_ne() for _, shape in scenario.world.shapes()]
        # The multicopter: a velocity of its own (it starts cruising along its yaw, as the
        # unicycle does) and a GPS bias, drawn only when it flies (the unicycle's random stream
        # stays as it was).
        self.vel_ne_mps = self.speed_mps * np.array([math.cos(self.pose[2]), math.sin(self.pose[2])])
        self._gps_bias_m: np.ndarray | None = None
        # The AHRS's slow yaw error (noise.yaw_bias_sigma_deg, Gauss-Markov over yaw_bias_tau_s):
        # drawn only when it has a sigma, so scenarios without one keep their random stream.
        self.yaw_bias_rad = 0.0
        if scenario.noise.yaw_bias_sigma_deg > 0.0:
            self.yaw_bias_rad = float(rng.normal(0.0,
                                                 math.radians(scenario.noise.yaw_bias_sigma_deg)))
        self.seen_ids: set[int] = set()          # obstacles ever in the camera's view
        # GPS outages: the velocity error of each, drawn only when there are outages (so
        # scenarios without keep their random stream)
        outages = scenario.noise.gps_outages_s
        self._outage_vel_ne_mps = [
            scenario.noise.outage_velocity_bias_mps
            * np.array([math.cos(a), math.sin(a)])
            for a in (rng.uniform(-math.pi, math.pi, len(outages)) if outages else ())]

    def gps_available(self) -> bool:
        """Whether the autopilot has a GPS fix now (noise.gps_outages_s)."""
        return self.scenario.noise.gps_outage_at(self.t_s) is None

    def obstacle_positions(self) -> np.ndarray:
        """True obstacle centres now, (n, 2)."""
        return self._obstacle_start + self._obstacle_vel * self.t_s

    def step(self, speed_cmd_mps: float, heading_change_rad: float) -> Odometry:
        """Advance one vehicle.dt_s: accel-limited speed, the given (already limited) heading change."""
        vehicle = self.scenario.vehicle
        dt = vehicle.dt_s
        max_dv = vehicle.max_accel_mps2 * dt
        self.speed_mps += max(-max_dv, min(max_dv, speed_cmd_mps - self.speed_mps))
        self.pose = move(self.pose, self.speed_mps, heading_change_rad, dt)
        self.t_s += dt
        noise = self.scenario.noise
        if self.speed_mps == 0.0 and heading_change_rad == 0.0:
            return Odometry(0.0, 0.0)       # a vehicle at rest knows it is still
        return Odometry(
            self.speed_mps + self.rng.normal(0.0, noise.speed_sigma_mps),
            heading_change_rad + self.rng.normal(0.0, math.radians(noise.heading_change_sigma_deg)))

    def step_copter(self, vel_cmd_ne_mps: np.ndarray, yaw_cmd_rad: float) -> CopterOdometry:
        """Advance one vehicle.dt_s as ArduCopter in GUIDED with the velocity + yaw mask: the
        velocity moves toward the command (acceleration-limited as a vector), the yaw turns
        toward the commanded yaw at max_turn_rate on its own, so course and heading differ."""
        vehicle = self.scenario.vehicle
        dt = vehicle.dt_s
        dv = np.asarray(vel_cmd_ne_mps, dtype=float) - self.vel_ne_mps
        dv_norm = float(np.hypot(*dv))
        max_dv = vehicle.max_accel_mps2 * dt
        if dv_norm > max_dv:
            dv *= max_dv / dv_norm
        mean_vel = self.vel_ne_mps + 0.5 * dv            # constant acceleration over the step
        self.vel_ne_mps = self.vel_ne_mps + dv
        max_turn = vehicle.max_turn_rate_rad_s * dt
        # ArduCopter turns by its own (AHRS) yaw: the true heading settles off by its bias
        turn = max(-max_turn, min(max_turn, wrap_angle(yaw_cmd_rad - self.pose[2]
                                                       - self.yaw_bias_rad)))
        self.pose = np.array([self.pose[0] + mean_vel[0] * dt, self.pose[1] + mean_vel[1] * dt,
                              wrap_angle(self.pose[2] + turn)])
        self.speed_mps = float(np.hypot(*self.vel_ne_mps))
        self.t_s += dt
        return self.copter_odometry(turn / dt)

    def copter_odometry(self, true_yaw_rate_rad_s: float) -> CopterOdometry:
        """The autopilot's noisy report of the present state (see CopterOdometry)."""
        noise, rng, dt = self.scenario.noise, self.rng, self.scenario.vehicle.dt_s
        tau = noise.position_bias_tau_s
        if self._gps_bias_m is None:
            self._gps_bias_m = rng.normal(0.0, noise.position_bias_sigma_m, 2)
        else:
            self._gps_bias_m = gauss_markov_step(self._gps_bias_m, noise.position_bias_sigma_m,
                                                 tau, dt, rng, 2)
        vel = self.vel_ne_mps + rng.normal(0.0, noise.velocity_sigma_mps, 2)
        outage = noise.gps_outage_at(self.t_s) if noise.gps_outages_s else None
        if outage is not None:
            vel = vel + self._outage_vel_ne_mps[outage]
        fix = self.pose[:2] + self._gps_bias_m + rng.normal(0.0, noise.position_sigma_m, 2)
        if noise.yaw_bias_sigma_deg > 0.0:
            self.yaw_bias_rad = float(gauss_markov_step(
                self.yaw_bias_rad, math.radians(noise.yaw_bias_sigma_deg), noise.yaw_bias_tau_s,
                dt, rng))
        return CopterOdometry(
            float(vel[0]), float(vel[1]),
            true_yaw_rate_rad_s + rng.normal(0.0, math.radians(noise.yaw_rate_sigma_deg_s)),
            wrap_angle(self.pose[2] + self.yaw_bias_rad
                       + rng.normal(0.0, math.radians(noise.yaw_sigma_deg))),
            (float(fix[0]), float(fix[1])))

    def step_vertical(self, climb_cmd_mps: float) -> float:
        """Advance the altitude one vehicle.dt_s toward the commanded climb rate (up positive),
        acceleration- and speed-limited; the ground stops it. Returns the altitude the autopilot
        reports (noisy: noise.altitude_sigma_m; the vertical random source). Call it after the
        horizontal step of the same dt."""
        vehicle = self.scenario.vehicle
        dt = vehicle.dt_s
        limit = vehicle.max_vertical_speed_mps
        target = max(-limit, min(limit, float(climb_cmd_mps)))
        max_dv = vehicle.max_accel_mps2 * dt
        new_vz = self.vel_up_mps + max(-max_dv, min(max_dv, target - self.vel_up_mps))
        self.altitude_m = max(0.0, self.altitude_m + 0.5 * (self.vel_up_mps + new_vz) * dt)
        self.vel_up_mps = new_vz if self.altitude_m > 0.0 else max(0.0, new_vz)
        return self.reported_altitude_m()

    def reported_altitude_m(self) -> float:
        sigma = self.scenario.noise.altitude_sigma_m
        return self.altitude_m + (float(self.vertical_rng.normal(0.0, sigma)) if sigma else 0.0)

    def _seen_heights(self, range_m: float, base_m: float, top_m: float) -> tuple | None:
        """The depths below the camera (FRD z) of the highest and lowest points of an extent
        [base_m, top_m] within the vertical view at ``range_m`` (noisy), or None if none is."""
        reach = range_m * math.tan(0.5 * self.scenario.sensor.vfov_rad)
        high = min(top_m, self.altitude_m + reach)
        low = max(base_m, 0.0, self.altitude_m - reach)
        if high < low:
            return None
        sigma = self._z_sigma_m(range_m)
        noise = self.vertical_rng.normal(0.0, sigma, 2)
        return (self.altitude_m - high + float(noise[0]), self.altitude_m - low + float(noise[1]))

    def _z_sigma_m(self, range_m: float) -> float:
        """A point's z error: a floor plus the elevation's (the bearing's sigma) times range."""
        return math.hypot(Z_SIGMA_FLOOR_M, range_m * self.scenario.sensor.bearing_sigma_rad)

    def ground_points(self) -> list[Observation]:
        """sensor.sees_ground: returns from the floor where the view's lower edge meets it
        (beyond altitude / tan(vfov / 2), within range), uniform over that area, id-less."""
        sensor = self.scenario.sensor
        if not sensor.sees_ground or self.altitude_m <= 0.0:
            return []
        near = self.altitude_m / math.tan(0.5 * sensor.vfov_rad)
        if near >= sensor.max_range_m:
            return []
        rng, out = self.vertical_rng, []
        for _ in range(sensor.ground_points_per_frame):
            range_m = math.sqrt(rng.uniform(near ** 2, sensor.max_range_m ** 2))
            depth = self.altitude_m + float(rng.normal(0.0, self._z_sigma_m(range_m)))
            out.append(Observation(range_m, float(rng.uniform(-0.5, 0.5) * sensor.fov_rad), None,
                                   top_down_m=depth, bottom_down_m=depth))
        return out

    def observe_sectors(self) -> tuple[np.ndarray, np.ndarray, float]:
        """One depth frame: per bin, the nearest obstacle surface along the ray through the bin's
        centre (ray-cast against every circle, wall and building), with range noise; a bin is missed with
        miss_probability; false alarms (as many as the centre form's, per frame) put a surface
        in a random bin at a range uniform over the view's area, if nearer than what is there.
        Returns (ranges_m (n,), NaN where nothing; bin-centre bearings (n,); increment_rad)."""
        sensor, rng = self.scenario.sensor, self.rng
        count, fov = sensor.sector_count, sensor.fov_rad
        increment = fov / count
        bearings = -0.5 * fov + increment * (np.arange(count) + 0.5)
        directions = self.pose[2] + bearings
        rays = np.column_stack((np.cos(directions), np.sin(directions)))        # (n, 2)
        ranges = self.surface_ranges(rays)
        centres = self.obstacle_positions() - self.pose[:2]
        seen = np.isfinite(ranges) & (ranges <= sensor.max_range_m)
        for oid, centre in zip(self.obstacle_ids, centres):
            if is_visible(math.hypot(*centre), wrap_angle(math.atan2(centre[1], centre[0])
                                                            - self.pose[2]),
                          fov, sensor.max_range_m):
                self.seen_ids.add(oid)
        if sensor.miss_probability:
            seen &= rng.random(count) >= sensor.miss_probability
        sigma = sensor.range_sigma_at(np.where(seen, ranges, 0.0))     # stereo: grows as r^2
        out = np.where(seen, ranges + rng.normal(0.0, sigma, count), np.nan)
        if sensor.false_alarm_rate_hz:
            for _ in range(rng.poisson(sensor.false_alarm_rate_hz / sensor.rate_hz)):
                i = int(rng.integers(count))
                r = max(FALSE_ALARM_MIN_RANGE_M, sensor.max_range_m * math.sqrt(rng.random()))
                out[i] = r if not np.isfinite(out[i]) else min(out[i], r)
        return out, bearings, increment

    def surface_ranges(self, rays: np.ndarray) -> np.ndarray:
        """Distance along each unit ray (n, 2) from the vehicle to the nearest surface of any
        obstacle, wall or building (inf where none), (n,); a shape a ray meets within the
        sensor's range counts as seen."""
        origin = self.pose[:2]
        ranges = shapes.ray_cast_circles(origin, rays, self.obstacle_positions(),
                                         self.obstacle_radii)
        for oid, corners in zip(self.shape_ids, self.shape_corners):
            hits = shapes.ray_cast_polygon(origin, rays, corners)
            if np.any(hits <= self.scenario.sensor.max_range_m):
                self.seen_ids.add(oid)
            ranges = np.minimum(ranges, hits)
        return ranges

    def capture_depth(self) -> list:
        """sensor.form depth: the DepthFrames due since the last call (every camera, at the
        camera's own rate, from the true pose with the tilt), handed to depth_sink too."""
        frames = self.depth_camera.frames_due(self)
        if self.depth_sink is not None and frames:
            self.depth_sink(frames)
        return frames

    def clearance(self) -> "Clearance":
        """How close the vehicle is now to every obstacle, wall and building (see Clearance)."""
        position = self.pose[:2]
        alt = self.altitude_m
        centre_m = surface_m = math.inf
        if len(self.obstacle_ids):
            gaps = shapes.circle_distance_m(position, self.obstacle_positions(),
                                            self.obstacle_radii)[0]
            # in 3D: also the height above the top or below the base (0 beside an obstacle,
            # always 0 for an unbounded one: the 2D figures, bit for bit)
            over = np.maximum(np.maximum(alt - self.obstacle_tops_m, self.obstacle_bases_m - alt),
                              0.0)
            centres = gaps + self.obstacle_radii
            if (over > 0.0).any():
                centre_m = float(np.where(over > 0.0, np.hypot(centres, over), centres).min())
                surface_m = float(np.where(over > 0.0, np.hypot(np.maximum(gaps, 0.0), over),
                                           gaps).min())
            else:           # beside every obstacle (every step in 2D): what the where()s pick
                centre_m, surface_m = float(centres.min()), float(gaps.min())
        shape_m = math.inf
        for corners, (base, top) in zip(self.shape_corners, self.shape_extents_m):
            gap = float(shapes.polygon_distance_m(position, corners)[0])
            over = max(alt - top, base - alt, 0.0)
            shape_m = min(shape_m, math.hypot(max(gap, 0.0), over) if over > 0.0 else gap)
        return Clearance(min(centre_m, shape_m), min(surface_m, shape_m))

    def observe(self) -> list[Observation]:
        """One camera frame: every obstacle centre in view, with R noise (the range's sigma
        growing with the range's square for a stereo camera, sensor.range_sigma_at), misses,
        false alarms."""
        sensor = self.scenario.sensor
        rng = self.rng
        frame = []
        # every obstacle's offset in one subtraction (per row, the same one), as Python floats
        offsets = (self.obstacle_positions() - self.pose[:2]).tolist()
        yaw = self.pose[2]
        for i, (oid, (d_north, d_east)) in enumerate(zip(self.obstacle_ids, offsets)):
            range_m = math.hypot(d_north, d_east)
            bearing = wrap_angle(math.atan2(d_east, d_north) - yaw)
            if not is_visible(range_m, bearing, sensor.fov_rad, sensor.max_range_m,
                              self.view_yaws_rad):
                continue
            heights = self._seen_heights(range_m, self.obstacle_bases_m[i],
                                         self.obstacle_tops_m[i])
            if heights is None:
                continue                   # wholly above or below the vertical view
            self.seen_ids.add(oid)
            if sensor.miss_probability and rng.random() < sensor.miss_probability:
                continue
            frame.append(Observation(
                range_m + rng.normal(0.0, sensor.range_sigma_at(range_m)),
                wrap_angle(bearing + rng.normal(0.0, sensor.bearing_sigma_rad)),
                oid if sensor.report_ids else None, top_down_m=heights[0],
                bottom_down_m=heights[1]))
        if sensor.false_alarm_rate_hz:
            # Clutter uniform over the area of the view (a spatial Poisson process, the usual
            # clutter model, and what the stub draws): the range's density grows with the range.
            # Uniform in range would put half the false alarms within 20 m of a 40 m camera.
            for _ in range(rng.poisson(sensor.false_alarm_rate_hz / sensor.rate_hz)):
                range_m = max(FALSE_ALARM_MIN_RANGE_M, sensor.max_range_m * math.sqrt(rng.random()))
                frame.append(Observation(range_m, rng.uniform(-0.5, 0.5) * sensor.fov_rad, None))
        return frame + self.ground_points()
