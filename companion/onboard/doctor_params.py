"""``companion doctor``: each autopilot's profile, and its parameters judged (pure).

The doctor keys everything autopilot-specific off HEARTBEAT.autopilot through :data:`PROFILES`:
the steering mode, the parameters to read (PARAM_REQUEST_READ) and how to judge them. The service
flies both (``supported`` None); a profile of an autopilot it does not fly says why not.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Callable

from companion.config.service import CompanionConfig
from companion.mavlink.doctor_codec import AUTOPILOT_ARDUPILOT, AUTOPILOT_PX4
from companion.onboard.doctor_facts import Facts

OK, WARN, FAIL = "ok", "warn", "fail"
AVOID_USE_PROXIMITY = 2            # AVOID_ENABLE bit: "use proximity sensor"
PRX_TYPE_MAVLINK = 2
# PX4 COM_OBL_RC_ACT (action once offboard is lost): what the vehicle does on its own then
PX4_OFFBOARD_LOSS_ACTIONS = {0: "Position mode", 1: "Altitude mode", 2: "Manual", 3: "Return",
                             4: "Land", 5: "Hold", 6: "Terminate", 7: "Disarm"}


@dataclass(frozen=True)
class Check:
    """One line of the checklist: what was measured, the verdict, what to do if not ok."""
    name: str
    status: str                    # ok | warn (flies, but read this) | fail (a blocker)
    measured: str
    todo: str = ""


@dataclass(frozen=True)
class AutopilotProfile:
    name: str
    supported: str | None          # None: the service flies it; else why not (a blocker)
    steering_mode: str             # the mode the companion's setpoints fly in
    params: tuple[str, ...]        # read with PARAM_REQUEST_READ
    judge: Callable[[Facts, CompanionConfig], list[Check]]


def coast(name: str, timeout_s: float, config: CompanionConfig) -> Check:
    """What a dead companion costs: the vehicle flies its last setpoint ``timeout_s`` (then
    stops). The union strategy's velocity choice takes a command only if flying it
    avoidance.horizon_s and then braking to rest keeps d from every mapped obstacle
    (core/avoidance/velocity_choice.py, arc.py): a timeout within the horizon is covered."""
    cruise = config.commanding.cruise_speed_mps
    d_m, horizon_s = config.safety_distance_m, config.avoidance.horizon_s
    coast_m = timeout_s * cruise
    measured = (f"{name} {timeout_s:g} s: if the companion dies the vehicle flies its last "
                f"setpoint that long, {coast_m:.1f} m at cruise {cruise:g} m/s, "
                f"{'more' if coast_m > d_m else 'less'} than d = {d_m:g} m")
    if config.avoidance.strategy == "union" and timeout_s <= horizon_s + 1e-9:
        return Check(name, OK, measured + f"; covered: each setpoint was checked to keep d from "
                     f"the mapped obstacles flown {horizon_s:g} s (avoidance.horizon_s) then "
                     f"braked to rest")
    if config.avoidance.strategy != "union":
        why = f"avoidance.strategy {config.avoidance.strategy} does not roll setpoints out"
    else:
        why = f"beyond avoidance.horizon_s {horizon_s:g} s, the span each setpoint is checked over"
    return Check(name, WARN, measured + f"; {why}",
                 f"set {name} <= {horizon_s:g} s (or avoidance.horizon_s >= {timeout_s:g} s "
                 f"with strategy union) so the coast stays within what was checked")


def _missing(name: str, why: str) -> Check:
    return Check(name, WARN, f"{name}: not read (PARAM_REQUEST_READ unanswered)",
                 f"run again; {why}")


def judge_ardupilot(facts: Facts, config: CompanionConfig) -> list[Check]:
    p = facts.params
    out = []
    if "GUID_TIMEOUT" in p:
        out.append(coast("GUID_TIMEOUT", p["GUID_TIMEOUT"], config))
    else:
        out.append(_missing("GUID_TIMEOUT", "ArduCopter has it: it is how long a vehicle flies on "
                                            "after its companion's setpoints stop"))
    if "WPNAV_ACCEL" in p:
        ap_mps2, ours = p["WPNAV_ACCEL"] / 100.0, config.commanding.max_accel_mps2
        text = (f"WPNAV_ACCEL {p['WPNAV_ACCEL']:g} cm/s/s: GUIDED shapes velocity setpoints with "
                f"{ap_mps2:g} m/s/s; the guidance plans with commanding.max_accel_mps2 {ours:g}")
        out.append(Check("WPNAV_ACCEL", OK, text) if ours <= 1.05 * ap_mps2 else Check(
            "WPNAV_ACCEL", WARN, text + ": it brakes later than planned",
            f"set commanding.max_accel_mps2: {ap_mps2:g} (or WPNAV_ACCEL {ours * 100:g})"))
    else:
        out.append(_missing("WPNAV_ACCEL", "the guidance assumes the vehicle's acceleration"))
    out.append(_proximity(p, config))
    oa = p.get("OA_TYPE")
    out.append(Check("OA_TYPE", OK, "OA_TYPE: not on this firmware" if oa is None else
                     f"OA_TYPE {oa:g}: " + ("off" if oa == 0 else
                                            "ArduPilot's path planner acts on its own waypoint "
                                            "navigation (AUTO, RTL, GUIDED position targets), "
                                            "not on the companion's velocity setpoints")))
    return out


def _proximity(p: dict[str, float], config: CompanionConfig) -> Check:
    """PRX1_TYPE, AVOID_ENABLE, AVOID_MARGIN: ArduCopter's own avoidance beside the companion."""
    prx, avoid, margin = p.get("PRX1_TYPE"), p.get("AVOID_ENABLE"), p.get("AVOID_MARGIN")
    if prx is None:
        return Check("proximity", OK, "PRX1_TYPE: not on this firmware (before 4.3: PRX_TYPE); "
                     "the companion avoids on its own")
    text = f"PRX1_TYPE {prx:g}"
    if prx == 0:
        return Check("proximity", OK, text + ": off; the companion avoids on its own "
                     "(2 gives ArduCopter its map as a backstop, docs/real-vehicle.md)")
    text += " (MAVLink: the companion's map reaches it)" if prx == PRX_TYPE_MAVLINK else \
        " (another sensor)"
    uses = avoid is not None and int(avoid) & AVOID_USE_PROXIMITY
    text += f", AVOID_ENABLE {avoid:g}" if avoid is not None else ""
    if not uses:
        return Check("proximity", OK, text + ": ArduCopter's avoidance does not use it")
    d_m = config.safety_distance_m
    if prx == PRX_TYPE_MAVLINK and config.map_out.rate_hz <= 2.0:
        return Check("proximity", WARN, text + f"; map_out.rate_hz {config.map_out.rate_hz:g}: "
                     "ArduPilot drops the sensor 500 ms after the last message",
                     "set map_out.rate_hz above 2 (5 is shipped)")
    if margin is not None and margin >= d_m:
        return Check("proximity", WARN, text + f", AVOID_MARGIN {margin:g} m >= d = {d_m:g} m: "
                     "ArduCopter brakes the companion's paths that pass d from an obstacle",
                     f"set AVOID_MARGIN below d (e.g. {max(d_m / 5.0, 1.0):g} m)")
    return Check("proximity", OK, text + (f", AVOID_MARGIN {margin:g} m" if margin is not None
                                          else "") + ": ArduCopter's avoidance is a backstop")


def judge_px4(facts: Facts, config: CompanionConfig) -> list[Check]:
    p = facts.params
    out = [coast("COM_OF_LOSS_T", p["COM_OF_LOSS_T"], config) if "COM_OF_LOSS_T" in p
           else _missing("COM_OF_LOSS_T", "PX4 has it: offboard loss after this long")]
    action = p.get("COM_OBL_RC_ACT")
    if action is None:
        out.append(_missing("COM_OBL_RC_ACT", "PX4 has it: what it does once offboard is lost"))
    else:
        name = PX4_OFFBOARD_LOSS_ACTIONS.get(int(action), f"action {action:g}")
        text = f"COM_OBL_RC_ACT {action:g}: once offboard is lost, {name}"
        if int(action) in (6, 7):
            out.append(Check("COM_OBL_RC_ACT", FAIL, text + ": the vehicle falls",
                             "set 5 (Hold) or 4 (Land)"))
        elif int(action) in (0, 4, 5):
            out.append(Check("COM_OBL_RC_ACT", OK, text))
        else:
            out.append(Check("COM_OBL_RC_ACT", WARN, text + " without the companion's avoidance "
                             "(Return flies home through whatever is in the way; Altitude and "
                             "Manual need a pilot)", "set 5 (Hold) unless a pilot stands by"))
    return out


ARDUPILOT = AutopilotProfile(
    "ArduPilot", None, "GUIDED",
    ("GUID_TIMEOUT", "WPNAV_ACCEL", "PRX1_TYPE", "AVOID_ENABLE", "AVOID_MARGIN", "OA_TYPE"),
    judge_ardupilot)
PX4 = AutopilotProfile("PX4", None, "OFFBOARD", ("COM_OF_LOSS_T", "COM_OBL_RC_ACT"), judge_px4)
PROFILES = {AUTOPILOT_ARDUPILOT: ARDUPILOT, AUTOPILOT_PX4: PX4}    # by HEARTBEAT.autopilot


def profile_for(autopilot: int | None) -> AutopilotProfile | None:
    return PROFILES.get(autopilot) if autopilot is not None else None
