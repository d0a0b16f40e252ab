"""Camera frames: obstacle reports checked, moved to vehicle time and gathered into frames.

One OBSTACLE_DISTANCE_3D per obstacle, all with the frame's time, are one chance for the landmark
lifecycle, not one each: the reports of one camera with one time are gathered (a frame in
assembly) until a message that is not part of it arrives, or, with ``link.camera_frame_idle_s``,
until that long has passed on the link's clock after its last report (``idle_due``; the service
asks when nothing arrives, replay at the next message's stamp: the same frames either way);
then the frame goes to the estimator and the commander decides on what it changed. A report of
a frame closed on idle time that comes after all is counted (``obstacle_after_frame_closed``)
and dropped: the frame was one chance, and it has been taken. Reports are taken from the vehicle's autopilot or
camera component; a camera stamping in Unix time (OBSTACLE_DISTANCE allows it) is moved to
vehicle time (TIMESYNC's offset, else the first frame's: safety/clock.py, safety/timesync.py).
"""
from __future__ import annotations

import dataclasses
import logging
from dataclasses import dataclass, field

from companion.core.perception.blobs import BlobParams, sector_observations
from companion.mavlink import codec
from companion.onboard.safety.clock import EpochCamera

log = logging.getLogger(__name__)

# Beyond this, a finite range is still nonsense (no stereo camera sees a kilometre): refused.
PLAUSIBLE_RANGE_M = 1000.0
LINK_STAMP_S = 1e-6     # the link's stamps are whole microseconds (and a sum of floats rounds)


@dataclass
class FrameAssembly:
    """One camera frame's observations, gathered from the messages that carry its time."""
    system_id: int
    component_id: int
    stamp_s: float                  # as the messages carry it (Unix time from an epoch camera)
    t_s: float                      # in vehicle time
    t_link_s: float
    observations: list = field(default_factory=list)
    last_link_s: float = 0.0        # the link time of its latest report

    @property
    def key(self) -> tuple[int, int, float]:
        return self.system_id, self.component_id, self.stamp_s

    def continued_by(self, event) -> bool:
        """Another message of this frame: an obstacle report from the same camera, same time."""
        return (isinstance(event, codec.ObstacleFrame) and event.t_s == self.stamp_s
                and (event.system_id, event.component_id) == (self.system_id, self.component_id))


class CameraFrames:
    """The frame in assembly (``assembly``), and the camera's clock if it stamps in Unix time.

    ``pipeline``: the pipeline this part serves (its config, clock, TIMESYNC, liveness,
    navigator and commander are read at each report, not copied here).
    """

    def __init__(self, pipeline) -> None:
        self._pipeline = pipeline
        self.assembly: FrameAssembly | None = None
        self.epoch_camera = EpochCamera()
        self.wants_timesync = False     # a camera stamps in Unix time: the service asks TIMESYNC
        self.idle_closed: tuple[int, int, float] | None = None   # the last frame closed on idle

    def idle_due(self, t_link_s: float) -> bool:
        """A frame is in assembly and ``link.camera_frame_idle_s`` has passed since its last
        report (never with the setting off)."""
        idle_s = self._pipeline.config.link.camera_frame_idle_s
        return (idle_s is not None and self.assembly is not None
                and t_link_s - self.assembly.last_link_s >= idle_s - LINK_STAMP_S)

    def idle_deadline_s(self) -> float | None:
        """Link time at which the frame in assembly is complete on idle time (the service waits
        for it); None: no frame waits, or the setting is off."""
        idle_s = self._pipeline.config.link.camera_frame_idle_s
        if idle_s is None or self.assembly is None:
            return None
        return self.assembly.last_link_s + idle_s

    def close_if_idle(self, t_link_s: float) -> list:
        """Nothing arrived by ``idle_deadline_s``: the frame is complete (the service's timer;
        replay closes it at the next message's stamp, Pipeline.handle)."""
        out: list = []
        if self.idle_due(t_link_s):
            self.close_idle(out)
        return out

    def close_idle(self, out: list) -> None:
        """The frame in assembly is complete on idle time: to the estimator (flush)."""
        self.idle_closed = self.assembly.key
        self.flush(out)

    def on_obstacles(self, t_link_s: float, frame: codec.ObstacleFrame, out: list) -> None:
        p = self._pipeline
        stamp_s = frame.t_s
        if frame.component_id not in (p.vehicle[1], p.config.link.camera_component_id):
            p.count("ignored_other_source")
            return
        if self.idle_closed == (frame.system_id, frame.component_id, stamp_s):
            p.count("obstacle_after_frame_closed")
            return
        frame = self.in_vehicle_time(frame, out)
        if frame is None:
            return
        verdict = p.clock.check_frame(frame.t_s, (t_link_s, frame))
        if not verdict.accepted:
            # Before the vehicle's clock (a reboot not yet seen in its own messages, or a
            # glitch) or ahead of it: it would be matched against the wrong pose.
            p.count("obstacle_time_ahead" if verdict.reason == "ahead" else "obstacle_too_old")
            return
        if frame.rejected:
            p.count("obstacle_rejected")
            log.debug("obstacle report refused: %s", frame.rejected)
            return
        p.liveness.on_camera_frame(frame.t_s, p.clock.latest_t_s)
        if p.navigator is None:
            if frame.observations:
                p.count("obstacle_before_estimator")
            return
        observations = [o for o in frame.observations if o.range_m <= PLAUSIBLE_RANGE_M]
        if len(observations) < len(frame.observations):
            p.count("observation_implausible_range")
            if not observations:
                return
        if frame.sectors is not None:        # a depth camera: its blobs, not a landmark per bin
            observations = sector_observations(frame.sectors, BlobParams(
                range_sigma_k_per_m=p.navigator.options.range_sigma_k_per_m))
        # Held until a message that is not part of this frame arrives (flush): an empty frame
        # too, a chance in which the landmarks in view were not seen.
        if self.assembly is None:
            self.assembly = FrameAssembly(frame.system_id, frame.component_id, stamp_s,
                                          frame.t_s, t_link_s)
        self.assembly.observations.extend(observations)
        self.assembly.last_link_s = t_link_s

    def flush(self, out: list) -> None:
        """The assembled camera frame to the estimator, and a decision on what it changed."""
        p = self._pipeline
        frame, self.assembly = self.assembly, None
        if p.navigator is None:
            return
        p.commander.sync_heights()
        reports = p.navigator.on_observations(frame.t_s, p.heights.frame(frame.observations))
        for report in reports:
            if report.action == "added":
                log.info("new landmark %s (obstacle id %s)", report.landmark_index,
                         report.obstacle_id)
        if reports and p.goal_ne is not None:
            p.commander.decide(frame.t_link_s, p.navigator.t_s, out)

    def in_vehicle_time(self, frame: codec.ObstacleFrame,
                        out: list) -> codec.ObstacleFrame | None:
        """A frame stamped in Unix time (OBSTACLE_DISTANCE allows it), moved to vehicle time by
        the offset of the first such frame; refused while the vehicle's clock is unknown."""
        p = self._pipeline
        if not self.epoch_camera.is_epoch(frame.t_s):
            return frame
        self.wants_timesync = True
        synced = p.timesync.vehicle_time_s(frame.t_s)
        if synced is not None:      # TIMESYNC's offset: no transport delay of one frame in it
            return dataclasses.replace(frame, t_s=synced)
        first = self.epoch_camera.offset_s is None
        t_s = self.epoch_camera.to_vehicle_time(frame.t_s, p.clock.latest_t_s)
        if t_s is None:
            p.count("obstacle_epoch_before_clock")
            return None
        if first:
            log.warning("camera stamps obstacle reports in Unix time: mapped to vehicle time by "
                        "the offset seen now (%.3f s)", self.epoch_camera.offset_s)
            out.append(codec.Notice(
                codec.SEVERITY_WARNING, "companion: camera in Unix time, offset mapped"))
        return dataclasses.replace(frame, t_s=t_s)
