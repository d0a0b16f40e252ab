"""A service's own depth frames (``perception.depth.source``): stamped on the vehicle's clock,
placed at the pose and the tilt of their capture, their observations into the estimator.

Without I/O: the service (companion/daemon/depth_feed.py) reads the frames and runs the heavy
perception (``DepthJob.perceive``, core/perception/depth_perception.py) off the event loop; this
part decides, from the ordered message stream, what a frame is perceived with and takes the
result in. Replay can drive it the same way.

- Time: the stub's frames carry the autopilot's ``time_boot_ms``; a camera's host time is
  mapped to vehicle time through TIMESYNC (safety/timesync.py) or, until it has answered, by
  the offset of the first frame (safety/clock.EpochCamera); a host time that is no Unix time
  (a recording's own stamps, as ``companion depth-record`` writes them) is vehicle time.
- Tilt: roll and pitch of the first ATTITUDE at or after the capture (the stub renders the
  frames between two steps with the later step's tilt; a real autopilot's ATTITUDE at 10-50 Hz
  is one period late at most). None yet: the frame waits for it (``job`` says "wait").
- Pose: the estimator's poses (core/perception/pose_history.py), one per odometry sample; the
  frame's points are moved by the motion from its capture to the latest estimate and go to the
  estimator at that estimate's time. A capture up to ``EXTRAPOLATE_S`` after the latest estimate
  (lock-step hands a step's frames over before the step's position) is placed by the last two
  estimates' rates, its yaw by that ATTITUDE's yaw rate (two estimates' difference missed the
  step's turn: bearings 2-3 degrees off, three landmarks a post in the depth demo); older than
  ``POSE_SPAN_S``, refused and counted.
- The mount is ``perception.depth.cameras[camera_id]``; the altitude above the floor is the
  flight phase's (above the takeoff point) at the latest estimate, carried there by its climb
  rate (the points are moved there); unknown: the floor is fitted.
"""
from __future__ import annotations

import logging
import math
from collections import Counter, deque
from dataclasses import dataclass

from companion.core.perception.depth_frame import CameraMount, DepthFrame
from companion.core.perception.depth_perception import (DepthPercept, DepthPerceptionParams,
                                                        MotionSince, perceive)
from companion.core.perception.pose_history import PoseHistory
from companion.onboard.safety.clock import EpochCamera

log = logging.getLogger(__name__)

POSE_SPAN_S = 2.0          # a frame perceived later than this after its capture is refused
EXTRAPOLATE_S = 0.25       # a capture this far past the latest estimate is still placed
ATTITUDE_HISTORY = 128     # ATTITUDEs kept for the tilt at capture (2.5 s at 50 Hz)
TIME_EPS_S = 1e-6


@dataclass(frozen=True)
class DepthJob:
    """Everything one frame's perception needs, taken from the stream at one point: what runs
    off the event loop (``perceive``) reads nothing else."""
    frame: DepthFrame
    t_capture_s: float               # the vehicle's clock
    t_estimate_s: float              # the estimate the observations are for
    mount: CameraMount
    roll_rad: float
    pitch_rad: float
    altitude_m: float | None
    motion: MotionSince
    params: DepthPerceptionParams

    def perceive(self) -> DepthPercept:
        return perceive(self.frame, self.mount, self.roll_rad, self.pitch_rad, self.altitude_m,
                        self.params, self.motion)


class DepthIntake:
    """The pipeline's depth part: tilts, poses, the camera clock, the counts."""

    def __init__(self, pipeline) -> None:
        self._pipeline = pipeline
        self.history = PoseHistory(POSE_SPAN_S, EXTRAPOLATE_S)
        # (t_s, roll, pitch, yaw rate) of the ATTITUDEs
        self.attitudes: deque[tuple[float, float, float, float]] = deque(maxlen=ATTITUDE_HISTORY)
        self.epoch_camera = EpochCamera()
        self.counts: Counter = Counter()
        self.last_delay_s: float | None = None     # capture -> the estimate it was used at

    # ------------------------------------------------------------ from the stream
    def on_attitude(self, t_s: float, roll_rad: float, pitch_rad: float,
                    yaw_rate_rad_s: float = 0.0) -> None:
        if math.isfinite(roll_rad) and math.isfinite(pitch_rad):
            self.attitudes.append((t_s, roll_rad, pitch_rad, yaw_rate_rad_s))

    def on_estimate(self, t_s: float, navigator, up_m: float | None) -> None:
        """The estimate after an odometry sample (north, east, yaw) and the altitude now."""
        north, east, yaw = (float(v) for v in navigator.slam.pose)
        self.history.add(t_s, north, east, yaw,
                         up_m if up_m is not None and math.isfinite(up_m) else math.nan)

    def reset(self) -> None:
        """The estimate restarts (reboot, divergence, position reset): no pose history."""
        self.history.clear()
        self.attitudes.clear()
        self.epoch_camera.forget()

    # ------------------------------------------------------------ a frame
    def capture_time_s(self, frame: DepthFrame, host_time_s: float | None) -> float | None:
        """The frame's capture on the vehicle's clock; None while it cannot be said."""
        if host_time_s is None:
            return frame.time_boot_ms / 1000.0
        p = self._pipeline
        if not self.epoch_camera.is_epoch(host_time_s):
            return host_time_s                        # a recording's own (vehicle) time
        p.frames.wants_timesync = True                # the service asks TIMESYNC
        synced = p.timesync.vehicle_time_s(host_time_s)
        if synced is not None:
            return synced
        return self.epoch_camera.to_vehicle_time(host_time_s, p.clock.latest_t_s)

    def job(self, frame: DepthFrame, t_capture_s: float | None,
            final: bool = False) -> DepthJob | str:
        """The frame's perception, or why not now: 'wait' (no ATTITUDE at or after the capture
        yet; ``final``: take the latest before it instead, if within
        commanding.max_attitude_age_s) or a refusal, counted as ``depth_<reason>``."""
        p = self._pipeline
        reason = self._refusal(frame, t_capture_s)
        if reason is not None:
            return self._refuse(reason)
        tilt = self._tilt_at(t_capture_s, final, p.config.commanding.max_attitude_age_s)
        if tilt is None:
            return "wait" if not final else self._refuse("no_attitude")
        motion = self.history.motion_since(t_capture_s, tilt[2])
        if motion is None:
            return self._refuse("outside_pose_history")
        depth = p.config.perception.depth
        params = depth.params(p.config.perception.ground_margin_m, depth.baseline_m,
                              depth.subpixel)
        now = self.history.at(self.history.latest_t_s)      # the points are moved to it
        altitude = now[3] if math.isfinite(now[3]) else None
        return DepthJob(frame, t_capture_s, self.history.latest_t_s,
                        depth.mounts()[frame.camera_id], tilt[0], tilt[1], altitude, motion,
                        params)

    def _refusal(self, frame: DepthFrame, t_capture_s: float | None) -> str | None:
        p = self._pipeline
        if p.navigator is None or self.history.latest_t_s is None:
            return "before_estimator"
        if t_capture_s is None or not math.isfinite(t_capture_s):
            return "time_unknown"
        if frame.camera_id >= len(p.config.perception.depth.mounts()):
            return "unknown_camera"
        return None

    def _refuse(self, reason: str) -> str:
        self.counts[reason] += 1
        return reason

    def _tilt_at(self, t_s: float, final: bool,
                 max_age_s: float) -> tuple[float, float, float] | None:
        """Roll, pitch and yaw rate of the first ATTITUDE at or after ``t_s``; ``final``: else
        of the latest before it, if within ``max_age_s``."""
        for t_att, roll, pitch, yaw_rate in self.attitudes:
            if t_att >= t_s - TIME_EPS_S:
                return roll, pitch, yaw_rate
        if final and self.attitudes and t_s - self.attitudes[-1][0] <= max_age_s:
            return self.attitudes[-1][1:]
        return None

    def absorb(self, t_link_s: float, job: DepthJob, percept: DepthPercept, out: list) -> None:
        """A frame's observations to the estimator (at the estimate they were placed for), and
        a decision on what they changed. The camera counts as live."""
        p = self._pipeline
        p.liveness.on_camera_frame(job.t_capture_s, p.clock.latest_t_s)
        self.counts.update(frames=1, points=percept.points, floor_points=percept.floor_points,
                           obstacle_points=percept.obstacle_points, holes=percept.holes,
                           observations=len(percept.observations), posts=len(percept.posts))
        if p.navigator is None:
            self.counts["after_reset"] += 1
            return
        self.last_delay_s = job.t_estimate_s - job.t_capture_s
        p.commander.sync_heights()
        reports = p.navigator.on_observations(job.t_estimate_s,
                                              p.heights.frame(percept.observations))
        for report in reports:
            if report.action == "added":
                log.info("new landmark %s from depth (frame %d, camera %d)",
                         report.landmark_index, job.frame.frame_number, job.frame.camera_id)
        if reports and p.goal_ne is not None:
            p.commander.decide(t_link_s, p.navigator.t_s, out)

    def snapshot(self) -> dict:
        """The report's ``depth`` block: frames perceived, points, refusals by reason."""
        return {"depth": dict(self.counts)} if self.counts else {}
