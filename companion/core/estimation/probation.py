"""Mover probation: a new landmark's sightings watched for motion, and the mover tracks.

A landmark seen for the first time is on probation for ``MoverParams.probation_s``: its world
points, placed from the dead-reckoned pose (odometry only, which a mover cannot drag along), are
watched for motion (core/estimation/movers.py, motion_evidence.py). If it moves, it is
marginalised out of the map and tracked; the pose never saw it. An old landmark refused by the
static map ``strikes_to_mover`` times in a row is taken for a mover too. The tracks themselves
are ``movers`` (a MoverTracker).
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from companion.core.estimation.estimator import SAME_TIME_TOLERANCE_S, Estimator
from companion.core.estimation.lifecycle import Lifecycle
from companion.core.estimation.motion_evidence import is_straight_track, shared_yaw_velocity_cov
from companion.core.estimation.movers import (MoverParams, MoverTracker, apparent_velocity,
                                              start_evidence, world_measurement)
from companion.core.estimation.slam_types import Observation, UpdateReport
from companion.core.geometry import place

MAX_MOVER_SPEED_MPS = 3.0      # an id-less young landmark may have moved this fast...
MOVED_GATE_M = 1.5             # ...plus this, between two sightings...
MOVED_MAX_GAP_S = 1.0          # ...at most this long apart (five frames missed in a row at 5 Hz):
                               # a young landmark unseen for longer is no track to extend (its reach
                               # would grow without bound and take another obstacle's sightings)
SIGHTING_ACTIONS = ("updated", "added", "outlier", "moved")   # the reports that saw the landmark


def nearest_other_m(points: np.ndarray, index: int) -> float:
    """The distance from ``points[index]`` to the nearest other of ``points`` (inf: none)."""
    points = np.asarray(points, dtype=float).reshape(-1, 2)
    if len(points) < 2:
        return math.inf
    gaps = np.hypot(*(points - points[index]).T)
    gaps[index] = math.inf
    return float(gaps.min())


def within_spacing(jump_m: float, neighbour_m: float, fraction: float) -> bool:
    """Whether a young landmark's jump of ``jump_m`` to a sighting may be its own motion, its
    nearest other landmark ``neighbour_m`` away: at most ``fraction`` of that distance. A mover
    moves continuously (a walker 0.3 m a frame at 5 Hz); a sighting as far off as the map's own
    spacing sits where a neighbour is or could be, and is no evidence of motion. At 0.5 the
    sighting is nearer the young landmark than its nearest neighbour, and than any other
    (triangle inequality: at least neighbour_m - jump_m >= jump_m from each)."""
    return jump_m <= fraction * neighbour_m


@dataclass
class Sightings:
    """A landmark on probation: its dead-reckoned world points and its last observation."""
    times: list = field(default_factory=list)
    points: list = field(default_factory=list)
    sigmas: list = field(default_factory=list)          # each point's standard deviation, m
    # ... of it, what is the point's own (the measurement's, the frame timing's), m
    free_sigmas: list = field(default_factory=list)
    # and what the pose's yaw error does (motion_evidence.shared_yaw_velocity_cov): each point's
    # range (m), world direction (rad), the yaw variance it was placed with (rad^2) and the
    # filter's running log yaw transfer then (Estimator.yaw_transfer_log)
    ranges: list = field(default_factory=list)
    directions: list = field(default_factory=list)
    yaw_vars: list = field(default_factory=list)
    yaw_logs: list = field(default_factory=list)
    last_obs: Observation | None = None
    # apparent_velocity's answer for the first n sightings, (n, velocity, sigma): the lists
    # only grow, and the answer depends on them alone, so each decision need not redo it
    apparent: tuple | None = None


class MoverProbation:
    """The landmarks on probation (``young``, by key), the strikes of old ones, the tracks."""

    def __init__(self, estimator: Estimator, lifecycle: Lifecycle, params: MoverParams) -> None:
        self.estimator = estimator
        self.lifecycle = lifecycle
        self.params = params
        self.movers = MoverTracker(params)
        self.movers_detected = 0
        self.young: dict[int, Sightings] = {}
        self._strikes: dict[int, int] = {}
        self._strike_points: dict[int, Sightings] = {}   # an old landmark's refused sightings
        noise = estimator.slam.noise
        self._point_sigma_m = math.hypot(noise.range_sigma_m, 40.0 * noise.bearing_sigma_rad)

    def start(self, key: int) -> None:
        """A new landmark ``key`` starts its probation."""
        self.young[key] = Sightings()

    def drop(self, key: int) -> None:
        """Landmark ``key`` left the map: its probation and strikes go with it."""
        self.young.pop(key, None)
        self._strikes.pop(key, None)
        self._strike_points.pop(key, None)

    def sight(self, key: int, obs: Observation, action: str) -> None:
        """A report of ``action`` on landmark ``key``: a sighting if it saw a landmark on
        probation."""
        young = self.young.get(key)
        if young is not None and action in SIGHTING_ACTIONS:
            self._add_sighting(young, obs)

    def _add_sighting(self, young: Sightings, obs: Observation) -> None:
        """Add an observation to sightings placed from the dead reckoning (``young_pose``)."""
        est = self.estimator
        young.times.append(est.clock_s)
        young.points.append(place(self.young_pose(),
                                  np.array([obs.range_m, obs.bearing_rad])))
        # A frame placed with an interpolated heading (its own odometry sample was lost) or
        # with a later one (it came late) may be misplaced sideways while the vehicle turns.
        # The multicopter's points take the filter's yaw, as uncertain as its variance says.
        yaw_sigma = math.sqrt(max(float(est.slam.pose_cov[2, 2]), 0.0)) \
            if est.options.motion_model == "velocity_ned" else 0.0
        point_sigma = self._point_sigma_m if obs.meas_cov is None else math.sqrt(
            obs.meas_cov[0][0] + obs.range_m ** 2 * obs.meas_cov[1][1])
        timing_sigma = obs.range_m * est.turn_rate_rad_s * est.frame_timing_s
        young.sigmas.append(math.hypot(point_sigma, timing_sigma, obs.range_m * yaw_sigma))
        # the yaw's share is common to the frames (shared_yaw_velocity_cov), the rest is not
        young.free_sigmas.append(math.hypot(point_sigma, timing_sigma, 0.0))
        young.ranges.append(obs.range_m)
        young.directions.append(float(self.young_pose()[2]) + obs.bearing_rad)
        young.yaw_vars.append(yaw_sigma ** 2)
        young.yaw_logs.append(est.yaw_transfer_log()
                              if est.options.motion_model == "velocity_ned" else 0.0)
        young.last_obs = obs

    def young_pose(self) -> np.ndarray:
        """The pose a young landmark's points are placed from: the dead reckoning (odometry only,
        which a mover on probation cannot drag along). The multicopter's dead-reckoned position
        does not depend on its yaw (its odometry is a NED velocity), and its dead-reckoned yaw
        is the autopilot's last sample, noisy per sample (2 deg: 1.2 m sideways at 35 m, enough
        to hide a crossing mover at 4.7 m/s from a 1.4 s motion test); the filter's yaw, the same
        samples fused with the gyro, is several times steadier and no young landmark corrects it
        (their updates are Schmidt's)."""
        est = self.estimator
        if est.options.motion_model != "velocity_ned":
            return est.dr_pose
        return np.array([est.dr_pose[0], est.dr_pose[1], float(est.slam.mean[2])])

    def moved(self, dr_point: np.ndarray, seen: set[int], taken: set[int]) -> int | None:
        """The young landmark whose last dead-reckoned point is near enough for a mover (one
        already ``seen`` in this frame, or ``taken`` by another of its observations, is not:
        nothing moves between two returns of one frame). With ``moved_spacing_gate`` (estimator
        options), not one whose jump is beyond that fraction of the distance from it to its
        nearest other landmark in the map (``within_spacing``)."""
        clock_s = self.estimator.clock_s
        fraction = self.estimator.options.moved_spacing_gate
        nearest_other = None if fraction is None else self._nearest_other_lookup()
        best, best_gap = None, math.inf
        for key, young in self.young.items():
            if key in seen or key in taken \
                    or clock_s - young.times[-1] > MOVED_MAX_GAP_S:
                continue
            gap = float(np.hypot(*(dr_point - young.points[-1])))
            reach = (MAX_MOVER_SPEED_MPS * (clock_s - young.times[-1]) + MOVED_GATE_M)
            if gap <= reach and gap < best_gap:
                if nearest_other is not None and not within_spacing(gap, nearest_other(key),
                                                                    fraction):
                    continue
                best, best_gap = key, gap
        return best

    def _nearest_other_lookup(self):
        """key -> the distance from that landmark to its nearest other in the filter now (inf:
        not in the filter, or alone)."""
        slam = self.estimator.slam
        index_of = {k: i for i, k in enumerate(slam.landmark_ids())}
        points = slam.landmarks()
        return lambda key: (nearest_other_m(points, index_of[key]) if key in index_of
                            else math.inf)

    def judge_refusal(self, oid: int, obs: Observation, report: UpdateReport,
                      used: set[int]) -> UpdateReport:
        """An id'd landmark's update ``report``: a refusal (outlier) is a strike. An old landmark
        refused ``strikes_to_mover`` times in a row is taken out of the map and tracked."""
        if report.action != "outlier":
            self._strikes.pop(oid, None)
            self._strike_points.pop(oid, None)
            return report
        self._strikes[oid] = self._strikes.get(oid, 0) + 1
        if oid not in self.young:
            self._add_sighting(self._strike_points.setdefault(oid, Sightings()), obs)
        if self._strikes[oid] < self.params.strikes_to_mover or oid in self.young:
            return report                    # a young landmark is judged by judge()
        # An old landmark refused twice in a row by the static map has started to move. Its
        # refused observations never touched map or pose: take it out of the map, track it,
        # at the velocity they show if they pass the motion test's speed test, else at rest.
        strikes = self._strike_points.pop(oid, None)
        shown = None if strikes is None else self.young_velocity(strikes, self.crab_speed())
        self._demote(oid, obs, used, None if shown is None else shown[:2],
                     None if shown is None else strikes)
        return UpdateReport("mover_detected", None, report.innovation, report.nis, oid)

    def _demote(self, oid: int, obs: Observation, used: set[int] | None = None,
                velocity: tuple[np.ndarray, float] | None = None,
                young: Sightings | None = None) -> None:
        """Marginalise landmark ``oid`` out of the map and start a mover track at ``obs``;
        ``young``: the sightings whose fit gave ``velocity``, the track starting when the last
        of them was seen, its position correlated with that velocity as the fit made it."""
        index = self.forget(oid)
        if used is not None:
            shifted = {i - 1 if i > index else i for i in used if i != index}
            used.clear()
            used.update(shifted)
        point, cov = self.world_point(obs)
        clock_s = self.estimator.clock_s
        start_s, cross = clock_s, None
        if young is not None and velocity is not None:
            start_s = min(clock_s, young.times[-1])
            cross = start_evidence(np.array(young.times), max(young.sigmas), velocity[1], cov)
        self.movers.create(start_s, point, cov, oid if oid >= 0 else None, velocity, cross)
        self.movers_detected += 1

    def judge(self) -> list[UpdateReport]:
        """This frame's verdict on every landmark on probation: expired, a mover (demoted to a
        track), established (static: probation over) or still watched."""
        params = self.params
        clock_s = self.estimator.clock_s
        detected = []
        crab = self.crab_speed()
        for oid, young in list(self.young.items()):
            # unseen for as long as a track coasts, and its sightings showed motion: it is not
            # where it was seen, and no longer where they extrapolate to; forgotten as a track is
            # (movers.prune), not left to be flown round for ever
            if clock_s - young.times[-1] > params.coast_s \
                    and self.young_velocity(young, crab) is not None:
                self.forget(oid)
                detected.append(UpdateReport("expired", None, None, None, oid))
                continue
            # Only the motion test judges a young landmark: refused outliers early on are more
            # often a poor pose at the frame's time (a lost sample under packet loss) than motion.
            # It runs before the probation ends, on every sighting: a mover seen for half a
            # second, out of view, then seen again once the probation is over is convicted by
            # its sightings, not established static (and then started from rest by its strikes)
            moving = False
            if young.times[-1] - young.times[0] >= params.min_span_s:
                velocity, sigma = self.apparent_velocity(young)
                # What a static obstacle seems to do: the dead reckoning's own drift (sigma) and,
                # for the unicycle, the vehicle's sideways motion it does not model (crab).
                speed = float(np.hypot(*velocity)) - crab
                moving = speed > params.speed_threshold_mps and speed > params.speed_sigmas * sigma
                # ... and the points are one object's straight track, not clutter that a fit
                # joins (two false alarms, or one beside a post's first sighting)
                moving = moving and is_straight_track(
                    young.times, young.points, self._track_sigmas(young))
            if moving:
                # the track starts at the velocity that convicted it: a mover that leaves the
                # view soon after is then predicted where it goes, not left standing
                self._demote(oid, young.last_obs, velocity=(velocity, sigma), young=young)
                detected.append(UpdateReport("mover_detected", None, None, None, oid))
                continue
            # established only once watched over min_span_s (or the whole probation, if
            # shorter): a mover seen for half a second and then out of view must not be taken
            # for a static obstacle
            if clock_s - young.times[0] > params.probation_s \
                    and len(young.times) >= self.estimator.options.established_sightings \
                    and young.times[-1] - young.times[0] >= min(params.min_span_s,
                                                                params.probation_s):
                del self.young[oid]             # watched long enough: established, static
        return detected

    def forget(self, oid: int) -> int:
        """Marginalise landmark ``oid`` out of the map with its probation and strikes, without
        a track (``_demote`` starts one); the state index it had."""
        self._strikes.pop(oid, None)
        self._strike_points.pop(oid, None)
        self.young.pop(oid, None)
        self.lifecycle.forget(oid)
        slam = self.estimator.slam
        index = slam.landmark_ids().index(oid)
        slam.remove_landmark(index)
        return index

    def apparent_velocity(self, young: Sightings) -> tuple[np.ndarray, float]:
        """A landmark on probation's apparent velocity and its sigma (movers.apparent_velocity):
        its points' own noise and the dead reckoning's drift, independent from frame to frame,
        plus the pose's yaw error, which is not (shared_yaw_velocity_cov: nearly the same in
        two frames 0.2 s apart, it mostly cancels in their difference; counted independent,
        two points at 35 m would give +-2.1 m/s where their errors are about 1 m/s). Zero for
        the unicycle, whose points are placed with the dead-reckoned yaw and carry no yaw term."""
        if young.apparent is not None and young.apparent[0] == len(young.times):
            return young.apparent[1].copy(), young.apparent[2]
        times = np.array(young.times)
        velocity, sigma = apparent_velocity(times, np.array(young.points), max(young.free_sigmas),
                                            self._dr_speed_sigma_mps(),
                                            self.estimator.odometry_dt_s())
        if max(young.yaw_vars) > 0.0:
            shared = shared_yaw_velocity_cov(times, young.ranges, young.directions,
                                             young.yaw_vars, young.yaw_logs)
            sigma = math.sqrt(sigma ** 2 + float(np.linalg.eigvalsh(shared)[-1]))
        young.apparent = (len(young.times), velocity.copy(), sigma)
        return velocity, sigma

    def _track_sigmas(self, young: Sightings) -> np.ndarray:
        """Each dead-reckoned point's sigma for the straight-track test: its own, plus the dead
        reckoning's random walk over the track's span (what a line does not absorb of it)."""
        span = young.times[-1] - young.times[0]
        walk_var = self._dr_speed_sigma_mps() ** 2 * self.estimator.odometry_dt_s() * span
        return np.sqrt(np.asarray(young.sigmas) ** 2 + walk_var)

    def _dr_speed_sigma_mps(self) -> float:
        options = self.estimator.options
        if options.motion_model == "velocity_ned":
            vel = options.velocity_noise
            return max(vel.vel_north_sigma_mps, vel.vel_east_sigma_mps)
        return self.estimator.slam.noise.speed_sigma_mps

    def crab_speed(self) -> float:
        """The largest unmodelled sideways speed over the probation window (paper model)."""
        return self.estimator.crab_speed(
            self.estimator.clock_s - self.params.probation_s - self.params.min_span_s)

    def world_point(self, obs: Observation) -> tuple[np.ndarray, np.ndarray]:
        """Where ``obs`` puts its object in the world, and that point's covariance (the pose's
        and the measurement's)."""
        slam = self.estimator.slam
        return world_measurement(slam.pose, slam.pose_cov,
                                 np.array([obs.range_m, obs.bearing_rad]),
                                 obs.meas_cov_array() if obs.meas_cov is not None
                                 else slam.noise.measurement_cov())

    def track_reach(self, point: np.ndarray) -> float:
        """How far from a mover track's prediction an id-less sighting at world ``point`` may
        lie and still be that mover's: with ``moved_spacing_gate`` (estimator options), that
        fraction of the distance from the point to its nearest landmark in the map, as for a
        young landmark that moved (``within_spacing``); else unbounded. In a forest a
        tree convicted as a mover by mistake coasts on, its prediction's ellipse growing with
        the time unseen, and took each tree coming into view 45-130 m off its prediction: never
        pruned, never mapped, flown round as a mover for 75 s (forest-dense 10 m/s, seed 67)."""
        fraction = self.estimator.options.moved_spacing_gate
        if fraction is None:
            return math.inf
        points = self.estimator.slam.landmarks()
        if not len(points):
            return math.inf
        return fraction * float(np.hypot(*(points - point).T).min())

    def update_mover(self, track_id: int, obs: Observation) -> UpdateReport:
        """Update mover track ``track_id`` with ``obs``."""
        point, cov = self.world_point(obs)
        nis = self.movers.update(track_id, self.estimator.clock_s, point, cov)
        return UpdateReport("mover", None, None, nis, obs.obstacle_id)

    def evidence(self) -> dict:
        """The landmarks on probation whose sightings so far already show motion, by key:
        (velocity, its sigma, the sightings' mean time); see ``young_velocity``."""
        crab = self.crab_speed()
        found = {}
        for key, young in self.young.items():
            shown = self.young_velocity(young, crab)
            if shown is not None:
                found[key] = shown
        return found

    def young_velocity(self, young: Sightings, crab: float) -> tuple | None:
        """(velocity, its sigma, the sightings' mean time) if a landmark on probation's
        sightings already show motion, else None. The conviction's speed test (speed_sigmas
        standard errors) on at least ``young_min_sightings`` of them; with the default 2, a
        crossing mover seen in two frames at the edge of the view, still tentative, shows its
        velocity (two points 0.2 s apart, each 0.1 m: +-0.74 m/s, so 3.7 m/s at 5 sigma).
        Tentative or not: a landmark seen too briefly to be confirmed is kept out of the
        decision as a possible false alarm, but a static false alarm does not move and two
        false alarms rarely fall within a mover's reach of each other."""
        if len(young.times) < self.params.young_min_sightings \
                or young.times[-1] - young.times[0] <= SAME_TIME_TOLERANCE_S:
            return None
        velocity, sigma = self.apparent_velocity(young)
        speed = float(np.hypot(*velocity)) - crab
        if speed > self.params.speed_threshold_mps \
                and speed > self.params.speed_sigmas * sigma:
            return velocity, sigma, float(np.mean(young.times))
        return None
