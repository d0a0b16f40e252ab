"""Scenario loading and validation, and the obstacles of the world.

`load_scenario(path)` is the only place that turns a scenario YAML file into config objects.
Frame: LOCAL_NED, x (north_m) and y (east_m) in metres from `world.origin`, yaw clockwise from
north. Degrees appear only in YAML keys ending in `_deg`; inside the stub everything is radians.

Sections the stub does not use (`avoidance`, `estimator`, `perception`) are accepted and ignored;
any other unknown key is rejected, because it is usually a typo.

Heights (issue 27): every obstacle, wall and building may have ``height_m`` (its top above the
ground, absent: unbounded, the 2D world's column) and ``base_m`` (its bottom, an overhang such as a
bridge deck; default 0). The ground is at altitude 0 (LOCAL_NED z = 0, the origin). A world with
a height, a base or ``sensor.sees_ground`` is a 3D world: its camera reports points with their
true z (camera.py); any other world's camera is the 2D one, its messages as before.
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import yaml

from . import shapes
from .depth_config import DepthSpec, Mount, parse_cameras, parse_depth

EARTH_RADIUS_M = 6378137.0  # WGS-84 equatorial radius, as ArduPilot's flat-earth conversion uses
UINT16_MAX = 65535


class ScenarioError(ValueError):
    """A scenario file could not be read or is invalid. The message names file, key and problem."""


@dataclass(frozen=True)
class Origin:
    lat_deg: float
    lon_deg: float
    alt_m: float

    def to_lat_lon_deg(self, north_m: float, east_m: float) -> tuple[float, float]:
        """Flat-earth conversion of a LOCAL_NED offset to latitude/longitude in degrees."""
        lat_deg = self.lat_deg + math.degrees(north_m / EARTH_RADIUS_M)
        lon_deg = self.lon_deg + math.degrees(
            east_m / (EARTH_RADIUS_M * math.cos(math.radians(self.lat_deg))))
        return lat_deg, lon_deg

    def to_north_east_m(self, lat_deg: float, lon_deg: float) -> tuple[float, float]:
        """The inverse of to_lat_lon_deg: (north_m, east_m) of a point from this origin."""
        north_m = math.radians(lat_deg - self.lat_deg) * EARTH_RADIUS_M
        east_m = (math.radians(lon_deg - self.lon_deg)
                  * EARTH_RADIUS_M * math.cos(math.radians(self.lat_deg)))
        return north_m, east_m


@dataclass(frozen=True)
class Pose:
    north_m: float
    east_m: float
    yaw_rad: float


@dataclass(frozen=True)
class Goal:
    north_m: float
    east_m: float
    radius_m: float


@dataclass(frozen=True)
class Obstacle:
    """A circular obstacle; it moves with a constant velocity (zero for a static one)."""
    obstacle_id: int
    north_m: float
    east_m: float
    radius_m: float
    vel_north_mps: float = 0.0
    vel_east_mps: float = 0.0
    height_m: float | None = None     # top above the ground (None: unbounded)
    base_m: float = 0.0               # bottom above the ground (an overhang)

    def position_at(self, t_s: float) -> tuple[float, float]:
        """(north_m, east_m) of the centre at simulated time t_s since start."""
        return (self.north_m + self.vel_north_mps * t_s, self.east_m + self.vel_east_mps * t_s)


@dataclass(frozen=True)
class Shape:
    """A static wall or building: a convex outline [(north_m, east_m)], counter-clockwise
    (shapes.py). Only the depth camera (sensor.form sectors or both) sees it."""
    obstacle_id: int
    kind: str                            # "wall" | "building"
    outline: tuple[tuple[float, float], ...]
    height_m: float | None = None        # as Obstacle's
    base_m: float = 0.0


@dataclass(frozen=True)
class WorldConfig:
    origin: Origin
    start: Pose
    goal: Goal
    obstacles: tuple[Obstacle, ...]
    shapes: tuple[Shape, ...] = ()

    @property
    def has_heights(self) -> bool:
        """Any obstacle, wall or building with a height or a base."""
        return any(item.height_m is not None or item.base_m > 0.0
                   for item in self.obstacles + self.shapes)


@dataclass(frozen=True)
class VehicleConfig:
    speed_mps: float
    max_turn_rate_rad_s: float
    max_accel_mps2: float
    dt_s: float
    kind: str = "unicycle"      # the odometry's noise model (the flight is ArduCopter's either way)


@dataclass(frozen=True)
class NoiseConfig:
    """Q: odometry noise, one sample of each per physics step; and the position's error.

    velocity_sigma_mps: extra white noise on each reported NED velocity axis.
    yaw_sigma_rad: white noise on the reported yaw (a compass-aided heading), on top of the
        integrated heading-change noise.
    yaw_rate_sigma_rad_s: white noise on the reported yaw rate (ATTITUDE yawspeed: a gyro).
    yaw_bias_sigma_rad, yaw_bias_tau_s: a slow error of the reported yaw (an AHRS's compass
        error: declination, soft iron, misalignment), a first-order Gauss-Markov process with
        this stationary sigma and correlation time, drawn at the start of a flight; the
        autopilot steers by the yaw it reports, so the true heading is off by the bias.
    position_sigma_m: None: no GPS (LOCAL_POSITION_NED x, y are the dead-reckoned odometry);
        else x, y = truth + a slow bias + white noise of this sigma per axis (GPS-like).
    position_bias_sigma_m, position_bias_tau_s: the bias, a first-order Gauss-Markov process
        per axis with this stationary sigma and correlation time.
    """
    speed_sigma_mps: float
    heading_change_sigma_rad: float
    velocity_sigma_mps: float = 0.0
    yaw_sigma_rad: float = 0.0
    yaw_rate_sigma_rad_s: float = 0.0
    yaw_bias_sigma_rad: float = 0.0
    yaw_bias_tau_s: float = 600.0
    position_sigma_m: float | None = None
    position_bias_sigma_m: float = 0.0
    position_bias_tau_s: float = 300.0
    # GPS outages ((start_s, duration_s), vehicle time; with a GPS only): no fix meanwhile, the
    # EKF's position relative only, LOCAL_POSITION_NED x, y dead-reckoned from the last fix with
    # the velocity, which carries an error of outage_velocity_bias_mps in a seeded direction per
    # outage (no longer GPS-aided); at the end the position resets to the GPS (as EKF3 does).
    gps_outages_s: tuple[tuple[float, float], ...] = ()
    outage_velocity_bias_mps: float = 0.0

    @property
    def has_gps(self) -> bool:
        return self.position_sigma_m is not None

    def gps_outage_at(self, t_s: float) -> int | None:
        """The index of the outage under way at t_s, or None."""
        for i, (start_s, duration_s) in enumerate(self.gps_outages_s):
            if start_s <= t_s < start_s + duration_s:
                return i
        return None


@dataclass(frozen=True)
class SensorConfig:
    fov_rad: float
    max_range_m: float
    rate_hz: float
    range_sigma_m: float
    bearing_sigma_rad: float
    report_ids: bool
    miss_probability: float
    false_alarm_rate_hz: float
    sector_message: bool = False
    form: str = "centres"          # centres | sectors (depth camera: ray-cast sectors only) | both
    sector_count: int = 72         # bins over the field of view (one OBSTACLE_DISTANCE holds 72)
    # stereo range noise: sigma_r(r) = range_sigma_m + range_sigma_k_per_m * r^2 (k in 1/m)
    range_sigma_k_per_m: float = 0.0
    # the vertical field of view (Intel's D455: 58 deg): in a 3D world an obstacle wholly above
    # or below it is not seen, and the points reported lie within it
    vfov_rad: float = math.radians(58.0)
    sees_ground: bool = False          # returns from the floor (a pitched depth camera)
    ground_points_per_frame: int = 4   # ... this many a frame, where the view meets the floor
    # form depth (depth_config.py): the rendered image and one mount per camera
    depth: DepthSpec | None = None
    cameras: tuple[Mount, ...] = ()

    def range_sigma_at(self, range_m: float) -> float:
        """Standard deviation of a range reported at true range ``range_m``, metres."""
        return self.range_sigma_m + self.range_sigma_k_per_m * range_m * range_m


SENSOR_FORMS = ("centres", "sectors", "both", "depth")


@dataclass(frozen=True)
class MissionConfig:
    max_time_s: float


@dataclass(frozen=True)
class Scenario:
    name: str
    world: WorldConfig
    vehicle: VehicleConfig
    noise: NoiseConfig
    sensor: SensorConfig
    mission: MissionConfig | None
    path: str = ""

    @property
    def reports_z(self) -> bool:
        """A 3D world (heights, bases or a floor-seeing camera): points carry their true z."""
        return self.world.has_heights or self.sensor.sees_ground


_TOP_KEYS = {"name", "world", "vehicle", "noise", "sensor", "mission"}
_IGNORED_TOP_KEYS = {"avoidance", "estimator", "perception"}  # the companion's; it validates them


class _Reader:
    """Typed access to one YAML mapping; every error names file and key path."""

    def __init__(self, path: str, data: Any, key_path: str) -> None:
        self.path = path
        self.key_path = key_path
        if not isinstance(data, dict):
            raise self.error(f"expected a mapping, got {_show(data)}")
        self.data = data
        self.used: set[str] = set()

    def error(self, problem: str, key: str | None = None) -> ScenarioError:
        full = f"{self.key_path}.{key}" if (key and self.key_path) else (key or self.key_path)
        return ScenarioError(f"{self.path}: {full or '<top>'}: {problem}")

    def _get(self, key: str, default: Any) -> Any:
        self.used.add(key)
        if key not in self.data:
            if default is _REQUIRED:
                raise self.error("missing required key", key)
            return default
        return self.data[key]

    def number(self, key: str, default: Any = None, *, minimum: float | None = None,
               strict_min: bool = False, maximum: float | None = None) -> float:
        value = self._get(key, _REQUIRED if default is None else default)
        if isinstance(value, bool) or not isinstance(value, (int, float)):
            raise self.error(f"expected a number, got {_show(value)}", key)
        value = float(value)
        if not math.isfinite(value):
            raise self.error(f"expected a finite number, got {value}", key)
        if minimum is not None and (value <= minimum if strict_min else value < minimum):
            raise self.error(f"must be {'>' if strict_min else '>='} {minimum:g}, got {value:g}", key)
        if maximum is not None and value > maximum:
            raise self.error(f"must be <= {maximum:g}, got {value:g}", key)
        return value

    def integer(self, key: str, *, minimum: int, maximum: int) -> int:
        value = self._get(key, _REQUIRED)
        if isinstance(value, bool) or not isinstance(value, int):
            raise self.error(f"expected an integer, got {_show(value)}", key)
        if not minimum <= value <= maximum:
            raise self.error(f"must be in [{minimum}, {maximum}], got {value}", key)
        return value

    def boolean(self, key: str, default: Any = None) -> bool:
        value = self._get(key, _REQUIRED if default is None else default)
        if not isinstance(value, bool):
            raise self.error(f"expected true or false, got {_show(value)}", key)
        return value

    def child(self, key: str, required: bool = True) -> "_Reader | None":
        value = self._get(key, _REQUIRED if required else None)
        if value is None and not required:
            return None
        return _Reader(self.path, value, f"{self.key_path}.{key}" if self.key_path else key)

    def finish(self, ignored: set[str] = frozenset()) -> None:
        unknown = sorted(set(map(str, self.data)) - self.used - set(ignored))
        if unknown:
            raise self.error("unknown key (typo?)", unknown[0])


_REQUIRED = object()


def _show(value: Any) -> str:
    return repr(value) if not isinstance(value, (dict, list)) else type(value).__name__


def load_scenario(path: str | Path) -> Scenario:
    """Read and validate a scenario file. Raises ScenarioError naming file, key and problem."""
    path_s = str(path)
    try:
        text = Path(path).read_text(encoding="utf-8")
    except OSError as exc:
        raise ScenarioError(f"{path_s}: cannot read: {exc.strerror or exc}") from exc
    try:
        data = yaml.safe_load(text)
    except yaml.YAMLError as exc:
        raise ScenarioError(f"{path_s}: not valid YAML: {exc}") from exc
    return parse_scenario(data, path_s)


def parse_scenario(data: Any, path: str = "<scenario>") -> Scenario:
    """Build a Scenario from already-parsed YAML data (see load_scenario)."""
    top = _Reader(path, data, "")
    name = top._get("name", "")
    if not isinstance(name, str):
        raise top.error(f"expected a string, got {_show(name)}", "name")
    world = _parse_world(top.child("world"))
    vehicle = _parse_vehicle(top.child("vehicle"))
    noise = _parse_noise(top.child("noise"))
    sensor = _parse_sensor(top.child("sensor"))
    mission_r = top.child("mission", required=False)
    mission = None
    if mission_r is not None:
        mission = MissionConfig(max_time_s=mission_r.number("max_time_s", minimum=0, strict_min=True))
        mission_r.finish()
    top.finish(ignored=_IGNORED_TOP_KEYS)
    if world.shapes and sensor.form == "centres":
        raise ScenarioError(f"{path}: sensor.form: centres cannot see walls or buildings (a "
                            "camera reporting centres says nothing about them): use sectors or both")
    return Scenario(name=name, world=world, vehicle=vehicle, noise=noise, sensor=sensor,
                    mission=mission, path=path)


def _parse_world(r: _Reader) -> WorldConfig:
    o = r.child("origin")
    origin = Origin(lat_deg=o.number("lat_deg", minimum=-90, maximum=90),
                    lon_deg=o.number("lon_deg", minimum=-180, maximum=180),
                    alt_m=o.number("alt_m"))
    o.finish()
    s = r.child("start")
    start = Pose(north_m=s.number("north_m"), east_m=s.number("east_m"),
                 yaw_rad=wrap_pi(math.radians(s.number("yaw_deg"))))
    # companion simulate's cruise altitude; the stub starts on the ground (a ground station's
    # takeoff sets the altitude), so it only checks it
    s.number("alt_m", 10.0, minimum=0, strict_min=True)
    s.finish()
    g = r.child("goal")
    goal = Goal(north_m=g.number("north_m"), east_m=g.number("east_m"),
                radius_m=g.number("radius_m", minimum=0, strict_min=True))
    g.finish()
    raw_obstacles = r._get("obstacles", [])
    if raw_obstacles is None:
        raw_obstacles = []
    if not isinstance(raw_obstacles, list):
        raise r.error(f"expected a list, got {_show(raw_obstacles)}", "obstacles")
    obstacles = []
    seen: set[int] = set()
    for i, item in enumerate(raw_obstacles):
        ob = _Reader(r.path, item, f"world.obstacles[{i}]")
        oid = ob.integer("id", minimum=0, maximum=UINT16_MAX - 1)
        if oid in seen:
            raise ob.error(f"duplicate obstacle id {oid}", "id")
        seen.add(oid)
        obstacles.append(Obstacle(
            obstacle_id=oid, north_m=ob.number("north_m"), east_m=ob.number("east_m"),
            radius_m=ob.number("radius_m", minimum=0, strict_min=True),
            vel_north_mps=ob.number("vel_north_mps", 0.0),
            vel_east_mps=ob.number("vel_east_mps", 0.0), **_extent(ob)))
        ob.finish()
    found = _parse_walls(r, seen) + _parse_buildings(r, seen)
    for shape, _ in found:
        for key, (n, e) in (("start", (start.north_m, start.east_m)),
                            ("goal", (goal.north_m, goal.east_m))):
            if shapes.surface_distance_m(n, e, list(shape.outline)) <= 0.0:
                raise r.error(f"the {key} lies inside {shape.kind} {shape.obstacle_id}", key)
    r.finish()
    return WorldConfig(origin=origin, start=start, goal=goal, obstacles=tuple(obstacles),
                       shapes=tuple(shape for shape, _ in found))


def _shape_list(r: _Reader, key: str) -> list:
    items = r._get(key, [])
    if items is None:
        return []
    if not isinstance(items, list):
        raise r.error(f"expected a list, got {_show(items)}", key)
    return items


def _shape_id(item: _Reader, seen: set[int]) -> int:
    oid = item.integer("id", minimum=0, maximum=UINT16_MAX - 1)
    if oid in seen:
        raise item.error(f"duplicate obstacle id {oid} (obstacles, walls and buildings share ids)",
                         "id")
    seen.add(oid)
    return oid


def _point(r: _Reader, key: str) -> tuple[float, float]:
    p = r.child(key)
    point = (p.number("north_m"), p.number("east_m"))
    p.finish()
    return point


def _parse_walls(r: _Reader, seen: set[int]) -> list[tuple[Shape, _Reader]]:
    out = []
    for i, item in enumerate(_shape_list(r, "walls")):
        w = _Reader(r.path, item, f"world.walls[{i}]")
        oid = _shape_id(w, seen)
        start, end = _point(w, "start"), _point(w, "end")
        thickness = w.number("thickness_m", minimum=0, strict_min=True)
        if math.hypot(end[0] - start[0], end[1] - start[1]) <= shapes.DEGENERATE_M:
            raise w.error("zero-length wall: end is the same point as start", "end")
        extent = _extent(w)
        w.finish()
        out.append((Shape(oid, "wall", tuple(shapes.wall_outline(start, end, thickness)),
                          **extent), w))
    return out


def _parse_buildings(r: _Reader, seen: set[int]) -> list[tuple[Shape, _Reader]]:
    out = []
    for i, item in enumerate(_shape_list(r, "buildings")):
        b = _Reader(r.path, item, f"world.buildings[{i}]")
        oid = _shape_id(b, seen)
        raw = b._get("corners", _REQUIRED)
        if not isinstance(raw, list):
            raise b.error(f"expected a list of corners, got {_show(raw)}", "corners")
        corners = []
        for j, corner in enumerate(raw):
            c = _Reader(r.path, corner, f"world.buildings[{i}].corners[{j}]")
            corners.append((c.number("north_m"), c.number("east_m")))
            c.finish()
        problem = shapes.outline_problem(corners)
        if problem is not None:
            raise b.error(problem, "corners")
        extent = _extent(b)
        b.finish()
        out.append((Shape(oid, "building", tuple(shapes.counter_clockwise(corners)), **extent), b))
    return out


def _extent(r: _Reader) -> dict:
    """``height_m`` (absent: unbounded) and ``base_m`` (default 0) of one obstacle, wall or
    building: a finite height > 0 above a finite base >= 0."""
    base_m = r.number("base_m", 0.0, minimum=0)
    if "height_m" not in r.data:
        r.used.add("height_m")
        return {"base_m": base_m}
    height_m = r.number("height_m", minimum=0, strict_min=True)
    if height_m <= base_m:
        raise r.error(f"must be above base_m ({base_m:g} m), got {height_m:g}", "height_m")
    return {"height_m": height_m, "base_m": base_m}


VEHICLE_KINDS = ("unicycle", "multicopter")


def _parse_vehicle(r: _Reader) -> VehicleConfig:
    # The stub always flies ArduCopter's GUIDED semantics (velocity, yaw turning on its own).
    # `kind` chooses the odometry's noise, as companion simulate's truth does: 'unicycle', speed
    # noise along the heading (the paper's Q); 'multicopter', white noise per NED velocity axis
    # only (noise.velocity_sigma_mps; speed_sigma_mps is then unused).
    kind = r._get("kind", "unicycle")
    if kind not in VEHICLE_KINDS:
        raise r.error(f"expected one of {', '.join(VEHICLE_KINDS)}, got {_show(kind)}", "kind")
    cfg = VehicleConfig(
        speed_mps=r.number("speed_mps", minimum=0, strict_min=True),
        max_turn_rate_rad_s=math.radians(r.number("max_turn_rate_deg_s", minimum=0, strict_min=True)),
        max_accel_mps2=r.number("max_accel_mps2", minimum=0, strict_min=True),
        dt_s=r.number("dt_s", minimum=0, strict_min=True, maximum=1.0), kind=kind)
    # companion simulate's truth may start cruising (the paper) or at rest; the stub's vehicle
    # always starts at rest on the ground and takes off, so either value is what it does anyway
    r.boolean("start_at_rest", False)
    r.finish()
    return cfg


def _parse_noise(r: _Reader) -> NoiseConfig:
    position_sigma = r.data.get("position_sigma_m")
    cfg = NoiseConfig(
        speed_sigma_mps=r.number("speed_sigma_mps", minimum=0),
        heading_change_sigma_rad=math.radians(r.number("heading_change_sigma_deg", minimum=0)),
        velocity_sigma_mps=r.number("velocity_sigma_mps", 0.0, minimum=0),
        yaw_sigma_rad=math.radians(r.number("yaw_sigma_deg", 0.0, minimum=0)),
        yaw_rate_sigma_rad_s=math.radians(r.number("yaw_rate_sigma_deg_s", 0.0, minimum=0)),
        yaw_bias_sigma_rad=math.radians(r.number("yaw_bias_sigma_deg", 0.0, minimum=0)),
        yaw_bias_tau_s=r.number("yaw_bias_tau_s", 600.0, minimum=0, strict_min=True),
        position_sigma_m=(None if position_sigma is None
                          else r.number("position_sigma_m", minimum=0)),
        position_bias_sigma_m=r.number("position_bias_sigma_m", 0.0, minimum=0),
        position_bias_tau_s=r.number("position_bias_tau_s", 300.0, minimum=0, strict_min=True),
        gps_outages_s=_outages(r),
        outage_velocity_bias_mps=r.number("outage_velocity_bias_mps", 0.0, minimum=0))
    r.used.add("position_sigma_m")
    r.finish()
    return cfg


def _outages(r: _Reader) -> tuple[tuple[float, float], ...]:
    value = r._get("gps_outages_s", [])
    if not isinstance(value, list):
        raise r.error(f"expected a list of [start_s, duration_s], got {_show(value)}",
                      "gps_outages_s")
    out = []
    for i, item in enumerate(value):
        if not (isinstance(item, list) and len(item) == 2
                and all(isinstance(v, (int, float)) and not isinstance(v, bool)
                        and math.isfinite(v) for v in item) and item[0] >= 0 and item[1] > 0):
            raise r.error(f"expected [start_s >= 0, duration_s > 0], got {_show(item)}",
                          f"gps_outages_s[{i}]")
        out.append((float(item[0]), float(item[1])))
    return tuple(out)


def _parse_sensor(r: _Reader) -> SensorConfig:
    form = _form(r)
    depth = parse_depth(r, _Reader) if form == "depth" else None
    if depth is not None and r.number("rate_hz", minimum=0, strict_min=True) != depth.rate_hz:
        raise r.error(f"expected the depth camera's rate (sensor.depth.rate_hz = "
                      f"{depth.rate_hz:g}), got {r.data['rate_hz']!r}", "rate_hz")
    cfg = SensorConfig(
        fov_rad=math.radians(r.number("fov_deg", minimum=0, strict_min=True, maximum=360)),
        max_range_m=r.number("max_range_m", minimum=0.2, strict_min=True),
        rate_hz=r.number("rate_hz", minimum=0, strict_min=True),
        range_sigma_m=r.number("range_sigma_m", minimum=0),
        bearing_sigma_rad=math.radians(r.number("bearing_sigma_deg", minimum=0)),
        report_ids=r.boolean("report_ids"),
        miss_probability=r.number("miss_probability", 0.0, minimum=0, maximum=1),
        false_alarm_rate_hz=r.number("false_alarm_rate_hz", 0.0, minimum=0),
        sector_message=r.boolean("sector_message", False),
        form=form,
        depth=depth, cameras=parse_cameras(r, _Reader, form),
        sector_count=r.integer("sector_count", minimum=2, maximum=72)
        if "sector_count" in r.data else 72,
        range_sigma_k_per_m=r.number("range_sigma_k_per_m", 0.0, minimum=0, maximum=1.0),
        vfov_rad=math.radians(r.number("vfov_deg", 58.0, minimum=0, strict_min=True,
                                       maximum=179.999)),
        sees_ground=r.boolean("sees_ground", False),
        ground_points_per_frame=r.integer("ground_points_per_frame", minimum=0, maximum=1000)
        if "ground_points_per_frame" in r.data else 4)
    r.finish()
    return cfg


def _form(r: _Reader) -> str:
    value = r._get("form", "centres")
    if value not in SENSOR_FORMS:
        raise r.error(f"expected one of {', '.join(SENSOR_FORMS)}, got {_show(value)}", "form")
    return value


def wrap_pi(angle_rad: float) -> float:
    """Wrap an angle to (-pi, pi]."""
    wrapped = math.fmod(angle_rad + math.pi, 2.0 * math.pi)
    if wrapped <= 0.0:
        wrapped += 2.0 * math.pi
    return wrapped - math.pi


def extents_of(world: WorldConfig) -> dict[int, tuple[float, float]]:
    """{id: (base_m, top_m)} of every obstacle, wall and building (top inf: unbounded)."""
    return {item.obstacle_id: (item.base_m, math.inf if item.height_m is None else item.height_m)
            for item in world.obstacles + world.shapes}


def obstacles_at(obstacles: tuple[Obstacle, ...] | list[Obstacle],
                 t_s: float) -> list[tuple[int, float, float, float]]:
    """[(id, north_m, east_m, radius_m)] of every obstacle at simulated time t_s."""
    out = []
    for ob in obstacles:
        n, e = ob.position_at(t_s)
        out.append((ob.obstacle_id, n, e, ob.radius_m))
    return out
