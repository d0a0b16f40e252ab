"""The stub's stereo camera beside any autopilot: component 100 of the vehicle's system.

Sans-I/O. Feed it every message heard on the link (`handle(msg, wall_s)`) and call
`poll(wall_s)` a few times a second; both return the messages to send. The loop that owns the
socket is `camera_only.py`.

What it does, in the autopilot's terms:
- The vehicle is the first autopilot heartbeat from component 1 (or the pinned system id); the
  camera speaks as (that system id, 100), MAV_TYPE_CAMERA, as the in-stub camera does.
- It asks for LOCAL_POSITION_NED and ATTITUDE (SET_MESSAGE_INTERVAL; REQUEST_DATA_STREAM as
  well if no request was ever accepted) and for GPS_GLOBAL_ORIGIN (MAV_CMD_REQUEST_MESSAGE),
  again while they stay away: ArduPilot streams nothing on a link until asked, and keeps the
  rates per link.
- Placement: LOCAL_POSITION_NED is relative to the EKF origin. The scenario frame is relative to
  `world.origin`; the EKF origin's latitude/longitude put one in the other
  (scenario = local + offset), or `--ekf-origin N,E` gives the offset when the autopilot does not
  say. No frames until the placement is known.
- Frames: on the first LOCAL_POSITION_NED at or after each nominal frame time (sensor.rate_hz on
  the autopilot's clock), from that position and the ATTITUDE yaw (carried forward by its yaw
  rate, at most MAX_ATTITUDE_AGE_S), through the stub's camera model (`camera.observe`);
  stamped with that message's time_boot_ms; `sensor.form` as the in-stub camera honours it
  (sectors: the nearest surface per bin, ray-cast against circles, walls and buildings; both:
  centres and sectors). The camera's view is the autopilot's estimate of the
  pose (in SITL within a few decimetres of the truth), level, at the vehicle's altitude: in a
  2D world the scenario's obstacles are columns; in a 3D world (world.py: heights, bases or
  sensor.sees_ground) the altitude is LOCAL_POSITION_NED -z (the EKF origin, on the ground at
  boot, is altitude 0) and the frames are the in-stub camera's 3D ones (two points per
  detection with their z, the floor's returns; camera.py), heights from their own stream.
- Moving obstacles start from their scenario positions when the vehicle first arms (a real
  autopilot needs tens of seconds before it can arm; the in-stub world starts at boot).
- Heartbeat at 1 Hz of the autopilot's time (so a speeded-up SITL sees it at 1 Hz of its own
  time), and at 1 Hz wall time while the autopilot's time stands still.
- A time_boot_ms more than 1 s behind the latest: the autopilot rebooted; placement (unless
  given), mover clock and schedules start afresh.
"""
from __future__ import annotations

import logging
import math
from dataclasses import dataclass

import numpy as np
from pymavlink.dialects.v20 import ardupilotmega as mavlink

from . import camera
from . import telemetry as tm
from .world import Origin, Scenario, extents_of, obstacles_at, wrap_pi

log = logging.getLogger(__name__)

REQUEST_RETRY_S = 2.0        # wall seconds between requests for what has not come yet
POSE_STALE_S = 3.0           # wall seconds without LOCAL_POSITION_NED: ask for the streams again
FALLBACK_AFTER_REQUESTS = 3  # SET_MESSAGE_INTERVAL tries before REQUEST_DATA_STREAM as well
MAX_ATTITUDE_AGE_S = 0.5     # autopilot seconds an ATTITUDE yaw may be carried forward
REBOOT_BACKSTEP_S = 1.0
HEARTBEAT_INTERVAL_S = 1.0
MIN_POSE_RATE_HZ = 10.0
MSG_ID_GPS_GLOBAL_ORIGIN = mavlink.MAVLINK_MSG_ID_GPS_GLOBAL_ORIGIN


@dataclass(frozen=True)
class Placement:
    """The autopilot's LOCAL_NED origin in the scenario frame: scenario = local + offset (m)."""
    north_m: float
    east_m: float
    source: str


def placement_from_origin(world_origin: Origin, lat_deg: float, lon_deg: float) -> Placement:
    north_m, east_m = world_origin.to_north_east_m(lat_deg, lon_deg)
    return Placement(north_m, east_m, "GPS_GLOBAL_ORIGIN")


@dataclass
class _Attitude:
    t_s: float
    yaw_rad: float
    yaw_rate_rad_s: float


class ExternalCamera:
    """The camera's state and decisions; every method returns the messages to send."""

    def __init__(self, scenario: Scenario, rng: np.random.Generator, sysid: int | None = None,
                 placement: Placement | None = None, sectors: bool | None = None) -> None:
        self.scenario = scenario
        self.cfg = scenario.sensor
        self.sectors = self.cfg.sector_message if sectors is None else sectors
        self._outlines = [list(shape.outline) for shape in scenario.world.shapes]
        self.rng = rng
        self._extents = extents_of(scenario.world)
        self._rng_heights = np.random.default_rng([int(rng.integers(2 ** 31)), 7]) \
            if scenario.reports_z else None
        self.sysid = sysid
        self._pinned_placement = placement
        self.placement = placement
        self.pose_rate_hz = max(MIN_POSE_RATE_HZ, 2.0 * self.cfg.rate_hz)
        self._frame_interval_s = 1.0 / self.cfg.rate_hz
        self.counters = dict(frames=0, reports=0, sector_messages=0, reboots=0,
                             stream_requests=0, origin_requests=0, skipped_no_attitude=0)
        self._reset_clock()
        self._last_pose_wall_s: float | None = None
        self._last_stream_request_wall_s: float | None = None
        self._last_origin_request_wall_s: float | None = None
        self._last_heartbeat_wall_s: float | None = None
        self._interval_accepted = False

    def _reset_clock(self) -> None:
        self.latest_t_s: float | None = None
        self.armed_t_s: float | None = None
        self._attitude: _Attitude | None = None
        self._next_frame_s = 0.0
        self._next_heartbeat_s = 0.0

    # ------------------------------------------------------------ inbound
    def handle(self, msg, wall_s: float) -> list:
        kind = msg.get_type()
        src = (msg.get_srcSystem(), msg.get_srcComponent())
        if kind == "HEARTBEAT":
            return self._on_heartbeat(msg, src, wall_s)
        if self.sysid is None or src != (self.sysid, mavlink.MAV_COMP_ID_AUTOPILOT1):
            if kind == "COMMAND_LONG" and self._addressed_to_us(msg):
                return [self._unsupported(msg)]
            return []
        if kind == "COMMAND_ACK":
            if msg.command == mavlink.MAV_CMD_SET_MESSAGE_INTERVAL \
                    and msg.result == mavlink.MAV_RESULT_ACCEPTED \
                    and msg.target_component in (0, tm.COMP_CAMERA):
                self._interval_accepted = True
            return []
        if kind == "GPS_GLOBAL_ORIGIN" and self._pinned_placement is None:
            self._on_origin(msg)
            return []
        if kind == "ATTITUDE":
            t_s = msg.time_boot_ms / 1000.0
            if self._clock(t_s):
                self._attitude = _Attitude(t_s, msg.yaw, msg.yawspeed)
            return self._heartbeat_due(wall_s)
        if kind == "LOCAL_POSITION_NED":
            t_s = msg.time_boot_ms / 1000.0
            self._last_pose_wall_s = wall_s
            if not self._clock(t_s):
                return []
            return self._heartbeat_due(wall_s) + self._frame(t_s, msg.x, msg.y, msg.z)
        return []

    def _on_heartbeat(self, msg, src: tuple[int, int], wall_s: float) -> list:
        is_autopilot = (msg.autopilot != mavlink.MAV_AUTOPILOT_INVALID
                        and src[1] == mavlink.MAV_COMP_ID_AUTOPILOT1)
        if self.sysid is None and is_autopilot:
            self.sysid = src[0]
            log.info("vehicle found: system %d; the camera is component %d", self.sysid,
                     tm.COMP_CAMERA)
            return self.poll(wall_s)
        if src == (self.sysid, mavlink.MAV_COMP_ID_AUTOPILOT1) and self.armed_t_s is None \
                and msg.base_mode & mavlink.MAV_MODE_FLAG_SAFETY_ARMED \
                and self.latest_t_s is not None:
            self.armed_t_s = self.latest_t_s
            log.info("vehicle armed at %.1f s: moving obstacles start", self.armed_t_s)
        return []

    def _on_origin(self, msg) -> None:
        placement = placement_from_origin(self.scenario.world.origin, msg.latitude / 1e7,
                                          msg.longitude / 1e7)
        if self.placement is None or (placement.north_m, placement.east_m) != (
                self.placement.north_m, self.placement.east_m):
            log.info("EKF origin at north %.2f m, east %.2f m of the scenario origin",
                     placement.north_m, placement.east_m)
        self.placement = placement

    def _clock(self, t_s: float) -> bool:
        """Track the autopilot's clock; False for a message to drop."""
        if not math.isfinite(t_s):
            return False
        if self.latest_t_s is not None and t_s < self.latest_t_s - REBOOT_BACKSTEP_S:
            log.warning("autopilot time went back %.1f s -> %.1f s: reboot, camera restarts",
                        self.latest_t_s, t_s)
            self.counters["reboots"] += 1
            self._reset_clock()
            self.placement = self._pinned_placement
            self._last_pose_wall_s = None
        self.latest_t_s = t_s if self.latest_t_s is None else max(self.latest_t_s, t_s)
        return True

    # ------------------------------------------------------------ frames and heartbeats
    def _frame(self, t_s: float, local_north_m: float, local_east_m: float,
               local_down_m: float = 0.0) -> list:
        if t_s + 1e-9 < self._next_frame_s or self.placement is None:
            return []
        yaw = self._yaw_at(t_s)
        if yaw is None or not (math.isfinite(local_north_m) and math.isfinite(local_east_m)):
            self.counters["skipped_no_attitude"] += 1
            return []
        north_m = local_north_m + self.placement.north_m
        east_m = local_east_m + self.placement.east_m
        motion_s = 0.0 if self.armed_t_s is None else max(0.0, t_s - self.armed_t_s)
        obstacles = obstacles_at(self.scenario.world.obstacles, motion_s)
        form = self.cfg.form
        heights = None
        if self._rng_heights is not None and math.isfinite(local_down_m):
            heights = camera.Heights(max(0.0, -local_down_m), self._extents, self._rng_heights)
        detections = ([] if form == "sectors" else
                      camera.observe(north_m, east_m, yaw, obstacles, self.cfg, self.rng,
                                     heights))
        out = [msg for det in detections for msg in tm.obstacle_points_3d(det, t_s, self.cfg)]
        floor = camera.ground_points(heights, self.cfg) \
            if heights is not None and form != "sectors" else []
        out += [tm.ground_point_3d(point, t_s, self.cfg) for point in floor]
        if form in ("sectors", "both"):
            # a depth camera: the nearest surface per bin, ray-cast against every circle, wall
            # and building from the autopilot's pose, as the in-stub camera does
            scan = camera.ray_cast_sectors_cm(
                north_m, east_m, yaw, obstacles, self.cfg, self.rng, self._outlines, heights,
                tuple(self._extents[shape.obstacle_id] for shape in self.scenario.world.shapes))
            out.append(tm.obstacle_distance([], t_s, self.cfg, scan))
            self.counters["sector_messages"] += 1
        elif self.sectors or not (detections or floor):
            # Nothing seen is still a frame (every sector at max_distance + 1), as the stub's
            # own camera and depth cameras send it: the receiver knows the camera is live.
            out.append(tm.obstacle_distance(detections, t_s, self.cfg))
            self.counters["sector_messages"] += 1
        self.counters["frames"] += 1
        self.counters["reports"] += len(detections)
        self._next_frame_s += self._frame_interval_s
        if self._next_frame_s <= t_s:
            self._next_frame_s = t_s + self._frame_interval_s
        return out

    def _yaw_at(self, t_s: float) -> float | None:
        att = self._attitude
        if att is None:
            return None
        gap_s = t_s - att.t_s
        if abs(gap_s) > MAX_ATTITUDE_AGE_S or not math.isfinite(att.yaw_rad):
            return None
        rate = att.yaw_rate_rad_s if math.isfinite(att.yaw_rate_rad_s) else 0.0
        return wrap_pi(att.yaw_rad + rate * gap_s)

    def _heartbeat_due(self, wall_s: float) -> list:
        t_s = self.latest_t_s
        if t_s is None or t_s + 1e-9 < self._next_heartbeat_s:
            return []
        self._next_heartbeat_s = max(self._next_heartbeat_s + HEARTBEAT_INTERVAL_S, t_s)
        self._last_heartbeat_wall_s = wall_s
        return [tm.heartbeat_camera()]

    # ------------------------------------------------------------ wall-clock duties
    def poll(self, wall_s: float) -> list:
        """Heartbeat while the autopilot's clock stands still; requests for what is missing."""
        if self.sysid is None:
            return []
        out = []
        if self._last_heartbeat_wall_s is None \
                or wall_s - self._last_heartbeat_wall_s >= HEARTBEAT_INTERVAL_S:
            self._last_heartbeat_wall_s = wall_s
            out.append(tm.heartbeat_camera())
        pose_stale = (self._last_pose_wall_s is None
                      or wall_s - self._last_pose_wall_s > POSE_STALE_S)
        if pose_stale and _due(self._last_stream_request_wall_s, wall_s):
            self._last_stream_request_wall_s = wall_s
            out += self._stream_requests()
        if self.placement is None and _due(self._last_origin_request_wall_s, wall_s):
            self._last_origin_request_wall_s = wall_s
            self.counters["origin_requests"] += 1
            out.append(self._command(mavlink.MAV_CMD_REQUEST_MESSAGE, MSG_ID_GPS_GLOBAL_ORIGIN))
        return out

    def _stream_requests(self) -> list:
        self.counters["stream_requests"] += 1
        interval_us = 1e6 / self.pose_rate_hz
        out = [self._command(mavlink.MAV_CMD_SET_MESSAGE_INTERVAL, msg_id, interval_us)
               for msg_id in (mavlink.MAVLINK_MSG_ID_LOCAL_POSITION_NED,
                              mavlink.MAVLINK_MSG_ID_ATTITUDE)]
        if not self._interval_accepted \
                and self.counters["stream_requests"] > FALLBACK_AFTER_REQUESTS:
            rate = int(round(self.pose_rate_hz))
            out += [mavlink.MAVLink_request_data_stream_message(
                self.sysid, mavlink.MAV_COMP_ID_AUTOPILOT1, stream, rate, 1)
                for stream in (mavlink.MAV_DATA_STREAM_POSITION, mavlink.MAV_DATA_STREAM_EXTRA1)]
        return out

    def _command(self, command: int, *params: float):
        values = list(params) + [0.0] * (7 - len(params))
        return mavlink.MAVLink_command_long_message(
            self.sysid, mavlink.MAV_COMP_ID_AUTOPILOT1, command, 0, *values)

    def _addressed_to_us(self, msg) -> bool:
        return self.sysid is not None and msg.target_system == self.sysid \
            and msg.target_component == tm.COMP_CAMERA

    def _unsupported(self, msg):
        return tm.command_ack(msg.command, mavlink.MAV_RESULT_UNSUPPORTED, msg.get_srcSystem(),
                              msg.get_srcComponent())


def _due(last_wall_s: float | None, wall_s: float) -> bool:
    return last_wall_s is None or wall_s - last_wall_s >= REQUEST_RETRY_S
