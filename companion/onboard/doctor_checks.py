"""``companion doctor``'s checklist: measured facts -> verdicts (pure).

:func:`evaluate` judges a :class:`~companion.onboard.doctor_facts.Facts` against the config:
the vehicle, each stream the service asks for, the EKF origin and position source, the obstacle
source, time sync, signing, the steering mode, the autopilot's parameters (doctor_params.py, by
HEARTBEAT.autopilot) and the config's own cross-checks. Each :class:`Check` says what was
measured, ``ok``, ``warn`` (it flies; read this) or ``fail`` (a blocker), and what to do.
docs/doctor.md explains every line.
"""
from __future__ import annotations

import statistics

from companion.config.service import CompanionConfig
from companion.mavlink import doctor_codec as dc
from companion.mavlink import px4_modes
from companion.onboard.doctor_facts import Facts
from companion.onboard.doctor_params import FAIL, OK, WARN, Check, profile_for

ODOMETRY_IDS = (30, 32)                    # ATTITUDE, LOCAL_POSITION_NED: the estimate runs on them
SLOW_ROUND_TRIP_MS = 100.0
COPTER_TYPES = {2, 3, 4, 13, 14, 15, 29, 35}  # quad, coaxial, heli, hexa, octo, tri, dodeca, deca
EKF_POS_HORIZ_REL, EKF_POS_HORIZ_ABS = 1 << 3, 1 << 4   # ESTIMATOR_POS_HORIZ_REL, _ABS
EKF_CONST_POS_MODE = 1 << 7
GPS_FIX_TYPE_NO_GPS = 0
CENTRE_TOLERANCE_DEG = 5.0


def evaluate(facts: Facts, config: CompanionConfig, needed_hz: dict[int, float],
             source: str = "the config") -> list[Check]:
    """The checklist, in the order a user fixes things: the config, the link and the vehicle
    first. ``needed_hz``: the streams the service asks for (daemon/streams.py), by message id."""
    vehicle = [config_check(config, source)] + vehicle_checks(facts)
    if facts.vehicle is None:
        return vehicle + [signing(facts, config)]
    profile = profile_for(facts.vehicle.autopilot)
    return (vehicle + streams(facts, config, needed_hz) + position(facts, config)
            + camera(facts, config) + [timesync(facts), signing(facts, config),
                                       steering(facts, config)]
            + (profile.judge(facts, config) if profile is not None else []))


def blockers(checks: list[Check]) -> list[Check]:
    return [c for c in checks if c.status == FAIL]


def config_check(config: CompanionConfig, source: str) -> Check:
    """The config loaded: every section's own checks passed (a bad one stops the doctor before
    it listens, as it stops ``companion run``)."""
    goal = config.goal
    where = ("none (give --goal to companion run)" if goal is None else "the autopilot's mission"
             if goal.mission else "lat/lon" if goal.is_geographic else
             f"north {goal.north_m:g} m, east {goal.east_m:g} m")
    return Check("config", OK, f"{source}: valid; d = {config.safety_distance_m:g} m at cruise "
                 f"{config.commanding.cruise_speed_mps:g} m/s, strategy "
                 f"{config.avoidance.strategy}; goal {where}")


# ------------------------------------------------------------------ the vehicle
def vehicle_checks(facts: Facts) -> list[Check]:
    v = facts.vehicle
    if v is None:
        return [Check("vehicle", FAIL, f"no autopilot heartbeat in {facts.listened_s:.0f} s",
                      "check the URL (udpin: listens, udpout: sends first), the baud rate, the "
                      "router's endpoint for the companion, and link.vehicle_system_id if set")]
    profile = profile_for(v.autopilot)
    firmware = str(facts.firmware) if facts.firmware else "not reported"
    text = (f"system {v.system_id}, component {v.component_id}, {dc.autopilot_name(v.autopilot)}"
            f", {dc.vehicle_type_name(v.mav_type)}, firmware {firmware}")
    out = [Check("vehicle", OK if facts.firmware else WARN, text,
                 "" if facts.firmware else "AUTOPILOT_VERSION unanswered: run again")]
    if profile is None:
        out.append(Check("autopilot", FAIL, f"{dc.autopilot_name(v.autopilot)}: not an autopilot "
                         "the service speaks", "connect to an ArduPilot (ArduCopter) vehicle"))
    elif profile.supported is not None:
        out.append(Check("autopilot", FAIL, f"{profile.name}: {profile.supported}",
                         "use an ArduPilot (ArduCopter) vehicle with this version"))
    if facts.other_autopilots:
        others = ", ".join(f"{s}/{c}" for s, c in facts.other_autopilots)
        out.append(Check("other autopilots", WARN, f"also heard: {others}",
                         "pin the vehicle: link.vehicle_system_id (and vehicle_component_id)"))
    return out


def streams(facts: Facts, config: CompanionConfig, needed_hz: dict[int, float]) -> list[Check]:
    fraction = config.streams.min_rate_fraction
    out = []
    for msg_id, need in needed_hz.items():
        name = f"{dc.message_name(msg_id)} ({msg_id})"
        got = facts.rates_hz.get(msg_id, 0.0)
        text = f"{name} {got:.1f} Hz, needs {need:g} Hz (at least {fraction * need:.1f})"
        if got >= fraction * need:
            out.append(Check(f"stream {name}", OK, text))
        elif got == 0.0 and msg_id in ODOMETRY_IDS:
            out.append(Check(f"stream {name}", FAIL, f"{name}: none in {facts.measured_s:.0f} s "
                             "after asking: the estimator cannot start",
                             "the vehicle refuses the stream: check SET_MESSAGE_INTERVAL reaches "
                             "it (router) and that it has a position (LOCAL_POSITION_NED needs "
                             "the EKF origin)"))
        else:
            out.append(Check(f"stream {name}", WARN, text + ": " + _slow_why(msg_id, got),
                             "another client on this link (a ground station or router at its "
                             "own rates) or a slow link: give the companion its own port or "
                             "raise the router's rates (SRn_ parameters)"))
    return out


def _slow_why(msg_id: int, got: float) -> str:
    if msg_id in ODOMETRY_IDS:
        return "estimate and decisions run at that rate"
    return {245: "the flight phase comes from the altitude instead",
            33: "no altitude above home (phase fallback), no lat/lon",
            24: "the position is not fused (GPS-denied SLAM)",
            193: "the position is not fused (GPS-denied SLAM)",
            230: "the position is not fused (GPS-denied SLAM)"}.get(msg_id, "missing") \
        if got == 0.0 else "slower than asked"


def position(facts: Facts, config: CompanionConfig) -> list[Check]:
    goal = config.goal
    needs_origin = config.fly_to.enabled or (goal is not None and
                                             (goal.is_geographic or goal.mission))
    if facts.origin is not None:
        origin = Check("EKF origin", OK, f"lat {facts.origin[0]:.7f}, lon {facts.origin[1]:.7f}")
    else:
        origin = Check("EKF origin", FAIL if needs_origin else WARN,
                       "not set (GPS_GLOBAL_ORIGIN unanswered)",
                       "wait for the EKF to have a position (ArduCopter: 30-40 s after boot with "
                       "GPS), or set the origin from the ground station")
    gps = facts.gps
    fix = (f"GPS fix type {gps.fix_type}, {gps.satellites if gps.satellites is not None else '?'}"
           f" satellites, HDOP {gps.hdop if gps.hdop is not None else '?'}") if gps else "no GPS_RAW_INT"
    ekf = f"EKF flags 0x{facts.ekf_flags:04x}" if facts.ekf_flags is not None else "no EKF_STATUS_REPORT"
    fusion = config.estimator.position_fusion
    text = f"{fix}; {ekf}"
    if fusion == "off":
        source = Check("position source", OK, text + ": not fused (position_fusion off: "
                       "GPS-denied SLAM by choice)")
    elif facts.position_trusted:
        source = Check("position source", OK, text + f": trusted, fused (position_fusion {fusion})")
    elif gps is not None and gps.fix_type == GPS_FIX_TYPE_NO_GPS:
        source = Check("position source", OK, text + ": no GPS connected: the estimate runs on "
                       "odometry and the map (GPS-denied SLAM)")
    else:
        source = Check("position source", WARN, text + ": not trusted now; the estimate runs on "
                       "odometry alone (GPS-denied SLAM) until it is",
                       "wait for a 3D fix and the EKF's absolute position (or fly GPS-denied "
                       "on purpose: position_fusion off)")
    return [origin, source]


def camera(facts: Facts, config: CompanionConfig) -> list[Check]:
    cam = facts.camera
    comp = cam.component_id
    out = []
    total_hz = sum(cam.msgs_hz.values())
    rates = ", ".join(f"{dc.message_name(m)} {hz:.1f}/s" for m, hz in sorted(cam.msgs_hz.items()))
    stale_hz = 1.0 / config.failsafe.obstacle_timeout_s
    if total_hz == 0.0:
        moved = "".join(f"; reports from component {c} ignored ({n})"
                        for c, n in sorted(cam.ignored.items()))
        out.append(Check("camera", FAIL if config.failsafe.require_camera else WARN,
                         f"component {comp}: heartbeat {'yes' if cam.heartbeat else 'none'}, no "
                         f"OBSTACLE_DISTANCE(_3D) in {facts.measured_s:.0f} s{moved}",
                         (f"set link.camera_component_id: {min(cam.ignored)}" if cam.ignored else
                          "start the camera driver; it must send with the vehicle's system id "
                          f"and component {comp} (link.camera_component_id), routed to the "
                          "companion") + "; without it the service holds (failsafe)"))
        return out
    text = (f"component {comp}: heartbeat {'yes' if cam.heartbeat else 'none'}; {rates}; "
            f"{cam.frames_hz:.1f} frames/s")
    cruise = config.commanding.cruise_speed_mps
    if cam.frames_hz < stale_hz:
        out.append(Check("camera", FAIL, text + ": below 1 per failsafe.obstacle_timeout_s",
                         "the service takes the camera for stale and holds: raise its rate"))
    elif cruise / cam.frames_hz > config.safety_distance_m / 4.0:
        out.append(Check("camera", WARN, text + f": {cruise / cam.frames_hz:.1f} m flown between "
                         "frames at cruise, more than d/4", "raise the camera's rate"))
    else:
        out.append(Check("camera", OK if cam.heartbeat else WARN, text,
                         "" if cam.heartbeat else "the camera sends reports but no heartbeat"))
    out.extend(_layout(layout, config) for layout in cam.layouts)
    out.append(_ranges(facts, config))
    return out


def _layout(layout: dc.ObstacleLayout, config: CompanionConfig) -> Check:
    name = dc.message_name(layout.msg_id)
    frame_ok = layout.frame == dc.FRAME_BODY_FRD or (
        layout.frame == 0 and layout.msg_id == dc.MSG_ID_OBSTACLE_DISTANCE)
    text = f"{name}: frame {layout.frame}"
    if not frame_ok:
        return Check(f"{name} frame", FAIL, text + ": the service reads BODY_FRD (12) only",
                     "have the camera driver send MAV_FRAME_BODY_FRD")
    if layout.msg_id == dc.MSG_ID_OBSTACLE_DISTANCE_3D:
        return _range_bound(f"{name} frame", text + " (BODY_FRD)", layout, config)
    text += (f", {layout.count} elements of {layout.increment_deg:g} deg from "
             f"{layout.angle_offset_deg:+g} deg")
    if layout.increment_deg <= 0 or layout.count * layout.increment_deg > 360.0 + 1e-6:
        return Check(f"{name} angles", FAIL, text + ": not a sector layout",
                     "increment (or increment_f) > 0 and elements x increment <= 360 deg")
    centre = layout.data_centre_deg
    span = layout.count * layout.increment_deg
    if centre is not None and span < 350.0 and abs(centre) > max(layout.increment_deg,
                                                                 CENTRE_TOLERANCE_DEG):
        return Check(f"{name} angles", WARN, text + f": the data is centred at {centre:+.1f} deg, "
                     "not on the nose", "angle_offset is element 0's angle: about -FOV/2 for a "
                     "forward camera (a driver sending 0 shifts every obstacle right)")
    return _range_bound(f"{name} angles", text + (f", data centred at {centre:+.1f} deg"
                                                  if centre is not None else ""), layout, config)


def _range_bound(name: str, text: str, layout: dc.ObstacleLayout,
                 config: CompanionConfig) -> Check:
    d_m = config.safety_distance_m
    if 0.0 < layout.max_distance_m < d_m:
        return Check(name, FAIL, text + f"; max_distance {layout.max_distance_m:g} m < d = "
                     f"{d_m:g} m: obstacles are seen only inside the safety distance",
                     "a camera with more range, or a smaller avoidance.safety_distance_m")
    return Check(name, OK, text)


def _ranges(facts: Facts, config: CompanionConfig) -> Check:
    cam = facts.camera
    refused = "".join(f"; {n} refused: {why}" for why, n in sorted(cam.refused.items()))
    if cam.observations == 0:
        return Check("ranges seen", WARN if cam.refused else OK,
                     "none: nothing in view" + refused,
                     "the reports are refused: see why" if cam.refused else "")
    text = (f"{cam.observations} observations, {cam.range_min_m:.1f} to {cam.range_max_m:.1f} m"
            + refused)
    return Check("ranges seen", WARN if cam.refused else OK, text,
                 "fix what the driver sends (refusals)" if cam.refused else "")


def timesync(facts: Facts) -> Check:
    trips = facts.round_trips_ms
    if not trips:
        return Check("time sync", WARN, f"TIMESYNC: 0 of {facts.timesync_sent} answered",
                     "needed only for a camera stamping in Unix time (its first frame's offset "
                     "is used instead); check the autopilot answers TIMESYNC")
    text = (f"TIMESYNC: {len(trips)} of {facts.timesync_sent} answered, round trip "
            f"{min(trips):.1f} ms (median {statistics.median(trips):.1f} ms)")
    if min(trips) > SLOW_ROUND_TRIP_MS:
        return Check("time sync", WARN, text + ": a slow link", "a faster link (baud rate)")
    return Check("time sync", OK, text)


def signing(facts: Facts, config: CompanionConfig) -> Check:
    ours = config.link.signing_key_file is not None
    text = f"vehicle packets: {facts.signed} signed, {facts.unsigned} unsigned"
    if ours:
        if facts.signature_rejected and facts.signed == 0:
            return Check("signing", FAIL, f"on (key {config.link.signing_key_file}); "
                         f"{facts.signature_rejected} packets refused, none verified",
                         "the vehicle signs with another key or not at all: set up signing "
                         "with the same key on both")
        return Check("signing", OK, f"on: {text}, {facts.signature_rejected} refused")
    if facts.signed:
        return Check("signing", FAIL, f"off here, but the vehicle signs ({text})",
                     "give link.signing_key_file the vehicle's key: a signing autopilot refuses "
                     "unsigned commands")
    return Check("signing", OK, f"off: {text} (on a shared link, consider link.signing_key_file)")


def steering(facts: Facts, config: CompanionConfig) -> Check:
    """Whether the steering mode can be entered, judged without entering it: the vehicle's kind
    (ArduCopter has GUIDED as custom mode 4), its custom modes flag, and the position
    ArduCopter needs to arm or fly in GUIDED."""
    v = facts.vehicle
    profile = profile_for(v.autopilot)
    if profile is None or profile.supported is not None:
        return Check("steering mode", FAIL, "not judged: autopilot not flown by this version",
                     "see the autopilot line")
    if profile.steering_mode == "OFFBOARD":
        return steering_px4(facts, config)
    mode = config.link.guided_custom_mode
    now = dc.copter_mode_name(v.custom_mode)
    if v.mav_type not in COPTER_TYPES or not v.custom_modes:
        return Check("steering mode", FAIL, f"{dc.vehicle_type_name(v.mav_type)}: not ArduCopter",
                     "the service flies multicopters (ArduCopter GUIDED)")
    text = f"{profile.steering_mode} = custom mode {mode} ({dc.copter_mode_name(mode)}); now {now}"
    if dc.copter_mode_name(mode) != profile.steering_mode:
        return Check("steering mode", FAIL, text, "set link.guided_custom_mode: 4 (ArduCopter)")
    if facts.ekf_flags is None:
        return Check("steering mode", WARN, text + "; position unknown (no EKF_STATUS_REPORT)",
                     "ArduCopter arms and flies in GUIDED only with a position estimate")
    flags = facts.ekf_flags
    if not flags & (EKF_POS_HORIZ_ABS | EKF_POS_HORIZ_REL) or flags & EKF_CONST_POS_MODE:
        return Check("steering mode", FAIL, text + "; no horizontal position in the EKF: "
                     "ArduCopter refuses to arm or switch to GUIDED armed",
                     "wait for the GPS fix / EKF origin (or an external position source)")
    return Check("steering mode", OK, text + "; the EKF has the position it needs")


def steering_px4(facts: Facts, config: CompanionConfig) -> Check:
    """PX4: OFFBOARD is accepted only after a setpoint stream of about a second, which the
    service sends while the vehicle is armed and airborne (onboard/autopilot_dialect.py), and
    PX4 needs a local position to fly it; who switches is px4.offboard's choice."""
    v = facts.vehicle
    now = px4_modes.mode_name(v.custom_mode)
    by = {"operator": "the operator switches (px4.offboard: operator)",
          "companion": "the service asks after the take-off (px4.offboard: companion)"}
    text = f"OFFBOARD, {by[config.px4.offboard]}; now {now}"
    if v.mav_type not in COPTER_TYPES:
        return Check("steering mode", FAIL, f"{dc.vehicle_type_name(v.mav_type)}: not a multicopter",
                     "the service flies multicopters")
    if facts.ekf_flags is None:
        return Check("steering mode", WARN, text + "; position unknown (no ESTIMATOR_STATUS)",
                     "PX4 refuses OFFBOARD velocity control without a local position")
    if not facts.ekf_flags & (EKF_POS_HORIZ_ABS | EKF_POS_HORIZ_REL):
        return Check("steering mode", FAIL, text + "; no horizontal position in the estimator",
                     "wait for the GPS fix (or an external position source)")
    return Check("steering mode", OK, text + "; the estimator has the position OFFBOARD needs")
