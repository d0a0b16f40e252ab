"""The service's odometry intake and the estimator's word to the ground station.

Kept out of pipeline.py so the pipeline only calls in: which motion model a LOCAL_POSITION_NED +
ATTITUDE sample feeds, whether the autopilot's position is trusted enough to fuse (position
fusion 'auto'), ODOMETRY's quality figure, and the notices when the estimator's state changes or
an arrival is uncertain. Knows codec events, never MAVLink fields.
"""
from __future__ import annotations

import logging
import math

from companion.mavlink import codec
from companion.config.sections import EstimatorConfig
from companion.core.estimation.slam_types import UpdateReport
from companion.core.avoidance.guidance import GuidanceCommand
from companion.core.navigation.navigator import Navigator
from companion.core.estimation.position_reset import PositionResetWatch, ResetVerdict, UnaidedDrift

log = logging.getLogger(__name__)

MIN_COURSE_SPEED_MPS = 0.5        # below this the velocity's direction is noise, not a course
QUALITY = {"ok": 100, "degraded": 50, "lost": -1}     # ODOMETRY.quality: -1 = failed
SEVERITY = {"ok": codec.SEVERITY_INFO, "degraded": codec.SEVERITY_WARNING,
            "lost": codec.SEVERITY_ERROR}
REFUSED_LOG_PERIOD_S = 10.0       # a refused autopilot position: said at once, then once per this


class ThrottledWarning:
    """A repeated warning: said the first time, then at most once per ``period_s`` of vehicle
    time with the count since it was last said (a fix refused every second for minutes would
    otherwise be a log line a second). ``total`` counts every occurrence."""

    def __init__(self, period_s: float = REFUSED_LOG_PERIOD_S) -> None:
        self.period_s = period_s
        self.total = 0
        self._unsaid = 0
        self._said_t_s: float | None = None

    def note(self, t_s: float) -> int | None:
        """One occurrence at vehicle time ``t_s``; returns how many to say now (this one and
        those held back since the last time said), or None: stay quiet. Time going backwards (a
        reboot) says it at once."""
        self.total += 1
        self._unsaid += 1
        said = self._said_t_s
        if said is not None and said <= t_s < said + self.period_s:
            return None
        count, self._unsaid, self._said_t_s = self._unsaid, 0, t_s
        return count


class PositionHealth:
    """Is the autopilot's horizontal position good enough to fuse, and with which sigma?

    'auto': the latest EKF_STATUS_REPORT says absolute horizontal position (no constant-position
    mode, no GPS glitch) and the latest GPS_RAW_INT has fix_type >= min_fix_type and HDOP <=
    max_hdop, both received within position_timeout_s of vehicle time.
    """

    def __init__(self, config: EstimatorConfig) -> None:
        self.config = config
        self._fix: tuple[float, codec.GpsFix] | None = None
        self._status: tuple[float, codec.EkfStatus] | None = None
        self._was_healthy: bool | None = None
        self.refusals = ThrottledWarning()      # the log of refused fixes (absorb)

    def note(self, event: codec.GpsFix | codec.EkfStatus, t_s: float | None) -> None:
        """An inbound GPS_RAW_INT or EKF_STATUS_REPORT, at the vehicle's latest time t_s."""
        if t_s is None:
            return
        if isinstance(event, codec.GpsFix):
            self._fix = (t_s, event)
        else:
            self._status = (t_s, event)

    def sigma_m(self, t_s: float) -> float | None:
        """The sigma to fuse the position with at t_s, or None: do not fuse."""
        config = self.config
        if config.position_fusion == "off":
            return None
        fix = self._fix[1] if self._fix is not None else None
        if config.position_fusion == "auto":
            healthy = self._healthy(t_s)
            if healthy != self._was_healthy:
                log.info("autopilot position %s: %s", "trusted" if healthy else "not trusted",
                         "fused" if healthy else "GPS-denied SLAM")
                self._was_healthy = healthy
            if not healthy:
                return None
        if config.position_sigma_m is not None:
            return config.position_sigma_m
        if fix is not None and fix.h_acc_m is not None:
            return fix.h_acc_m
        hdop = fix.hdop if fix is not None and fix.hdop is not None else 1.0
        return hdop * config.position_sigma_per_hdop_m

    def aided(self, t_s: float) -> bool:
        """Whether the autopilot's velocity is GPS-aided, as far as we can tell: 'auto' sees its
        position trusted; 'on' and 'off' do not judge, so they never call it unaided."""
        return self.config.position_fusion != "auto" or self._healthy(t_s)

    def _healthy(self, t_s: float) -> bool:
        config = self.config
        if self._fix is None or self._status is None:
            return False
        (fix_t, fix), (status_t, status) = self._fix, self._status
        fresh = max(t_s - fix_t, t_s - status_t) <= config.position_timeout_s
        return (fresh and status.horizontal_position_ok and fix.fix_type >= config.min_fix_type
                and fix.hdop is not None and fix.hdop <= config.max_hdop)


def absorb(nav: Navigator, config: EstimatorConfig, health: PositionHealth,
           lpn: codec.LocalPosition, yaw_rad: float, yaw_rate_rad_s: float,
           watch: PositionResetWatch | None = None, drift: UnaidedDrift | None = None
           ) -> tuple[list[UpdateReport], ResetVerdict | None]:
    """One odometry sample into the navigator through the configured motion model, then the
    autopilot's position if it is trusted. Returns the observation reports it released and, when
    a fix was judged, the reset watch's verdict on it (reset: restart the estimate from it)."""
    if config.motion_model == "velocity_ned":
        reports = nav.on_velocity(lpn.t_s, lpn.vel_north_mps, lpn.vel_east_mps, yaw_rad,
                                  yaw_rate_rad_s)
    else:
        speed = math.hypot(lpn.vel_north_mps, lpn.vel_east_mps)
        course = math.atan2(lpn.vel_east_mps, lpn.vel_north_mps) \
            if speed >= MIN_COURSE_SPEED_MPS else None
        reports = nav.on_odometry(lpn.t_s, speed, yaw_rad, course)
    verdict = None
    if nav.t_s == lpn.t_s and drift is not None:
        nav.slam.inflate_position(drift.step(lpn.t_s, health.aided(lpn.t_s)))
    if nav.t_s == lpn.t_s:
        sigma = health.sigma_m(lpn.t_s)
        if sigma is not None:
            report = nav.correct_position(lpn.north_m, lpn.east_m, sigma)
            if report is not None and report.action == "outlier":
                count = health.refusals.note(lpn.t_s)
                if count == 1:
                    log.warning("autopilot position refused: NIS %.0f (%.1f, %.1f m off)",
                                report.nis, *report.innovation)
                elif count is not None:
                    log.warning("autopilot position refused %d times in %.0f s (%d in all); "
                                "the latest: NIS %.0f (%.1f, %.1f m off)", count,
                                health.refusals.period_s, health.refusals.total, report.nis,
                                *report.innovation)
            if report is not None and watch is not None:
                verdict = watch.on_fix(lpn.t_s, report.action, report.innovation)
    return reports, verdict


def quality(nav: Navigator) -> int:
    """ODOMETRY.quality from the estimator's state (0: not assessed yet)."""
    return QUALITY[nav.health.state] if nav.health is not None else 0


class EstimatorNotices:
    """STATUSTEXT notices on estimator state changes and uncertain arrivals (the service's
    STATUSTEXT limiter rate-limits them; here: one per change)."""

    def __init__(self) -> None:
        self._nav: Navigator | None = None
        self._reported = 0              # health changes of that navigator already announced
        self._uncertain = False

    def after_decision(self, nav: Navigator, command: GuidanceCommand) -> list[codec.Notice]:
        out = []
        if nav is not self._nav:        # a new estimate (after a reboot): its own history
            self._nav, self._reported, self._uncertain = nav, 0, False
        changes = nav.health_changes
        for change in changes[self._reported:]:
            if self._reported == 0 and change.state == "ok":
                continue                   # the first assessment being ok is no news
            text = f"companion: estimator {change.state}"
            if change.reason:
                text += f": {change.reason}"
            log.log(logging.INFO if change.state == "ok" else logging.WARNING, "%s at %.1f s",
                    text, change.t_s)
            out.append(codec.Notice(SEVERITY[change.state], text))
        self._reported = len(changes)
        uncertain = command.mode == "arrival_uncertain"
        if uncertain and not self._uncertain:
            radius = nav.health.radius_2sigma_m
            log.warning("arrival uncertain: pose 2-sigma %.1f m", radius)
            out.append(codec.Notice(codec.SEVERITY_WARNING,
                                    f"companion: arrival uncertain (+-{radius:.1f} m)"))
        self._uncertain = uncertain
        return out


def snapshot(nav: Navigator | None) -> dict:
    """The estimator's health for the run JSON."""
    if nav is None:
        return {"estimator_state": None, "estimator_state_changes": [], "position_fixes": {}}
    return {
        "estimator_state": nav.health.state if nav.health is not None else None,
        "estimator_state_changes": [
            {"t_s": h.t_s, "state": h.state, "reason": h.reason,
             "radius_2sigma_m": h.radius_2sigma_m} for h in nav.health_changes],
        "position_fixes": dict(nav.position_fixes),
    }
