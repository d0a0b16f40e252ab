"""How the navigator estimates (motion model, fusion, probation) and how it acts on its health.

``moderate`` is the arrival rule and the reaction to the consistency monitor's state, applied to
every guidance command: pure, so a test can say why a command was changed.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, replace

from companion.core.estimation.consistency import Consistency, MonitorParams, chi2_quantile
from companion.core.estimation.slam_types import chi2_2dof_quantile, VelocityNoise
from companion.core.avoidance.guidance import GuidanceCommand
from companion.core.estimation.lifecycle import LifecycleParams
from companion.core.estimation.map_archive import ArchiveParams

MOTION_MODELS = ("paper", "velocity_ned")
REACTIONS = ("none", "slow", "hold")


@dataclass(frozen=True)
class EstimatorOptions:
    """How the navigator estimates and how it reacts to its own health.

    motion_model: 'paper' (the unicycle: speed along the yaw, the yaw difference as the heading
    change) or 'velocity_ned' (a multicopter: the autopilot's NED velocity, the yaw a state of its
    own driven by the yaw rate and corrected by the autopilot's yaw, ``yaw_sigma_rad``).
    Position fixes (``correct_position``) are fused at most once per ``position_period_s``.
    A landmark corrects the pose only once established: past probation and seen
    ``established_sightings`` times. Arrival needs the pose's 2-sigma radius within
    ``arrival_tolerance_m``. ``lifecycle``: tentative / confirmed / deleted (core/estimation/lifecycle.py). Reactions to 'degraded' / 'lost': 'none', 'slow' (speed times
    ``slow_factor``) or 'hold'. ``range_sigma_k_per_m``: the filter's range sigma grows as
    floor + k r^2 (core/estimation/range_noise.py; the floor is SlamNoise.range_sigma_m), 0: constant.
    ``yaw_bias_sigma_rad``, ``yaw_bias_tau_s``: the autopilot's yaw error is white
    (``yaw_sigma_rad``) plus a slow bias (a compass's: Gauss-Markov, this sigma and correlation
    time), so successive yaw samples are not independent (``yaw_fix_sigma_rad``).
    """
    motion_model: str = "paper"
    velocity_noise: VelocityNoise = VelocityNoise(0.1, 0.1, math.radians(0.5))
    yaw_sigma_rad: float = math.radians(2.0)
    yaw_gate_nis: float = chi2_quantile(0.99999, 1)
    position_gate_nis: float = chi2_2dof_quantile(0.99999)
    position_period_s: float = 1.0
    established_sightings: int = 5
    arrival_tolerance_m: float = 2.0
    monitor: MonitorParams = MonitorParams()
    degraded_reaction: str = "slow"
    lost_reaction: str = "hold"
    slow_factor: float = 0.5
    lifecycle: LifecycleParams = LifecycleParams()
    range_sigma_k_per_m: float = 0.0
    range_sigma_at_predicted: bool = False  # updates evaluate that sigma at the landmark's
                                          # predicted range, not the measured one (range_noise.py)
    yaw_bias_sigma_rad: float = 0.0
    yaw_bias_tau_s: float = 600.0
    velocity_in_yaw_frame: bool = False     # velocity_ned: see EkfSlam.predict_velocity
    archive: ArchiveParams | None = None   # the bounded map (core/estimation/map_archive.py); None: off
    new_beside_tentative: bool = False    # an id-less observation that only came near a tentative
                                          # landmark no other observation of the frame took (the
                                          # gate's grey zone) starts a new landmark instead of
                                          # being dropped (forests: a misplaced tentative trunk
                                          # swallowed every sighting of its neighbour; docs/forest.md)
    moved_spacing_gate: float | None = None  # a young landmark is taken to have 'moved' to an
                                          # unassociated sighting only if the jump is at most this
                                          # fraction of the distance from it to its nearest other
                                          # landmark (probation.within_spacing; forests: at 2.5 m
                                          # spacing the neighbour's sighting; docs/forest.md
                                          # item 15); and an id-less sighting joins a mover
                                          # track only as near its prediction (a tree convicted
                                          # by mistake took the trees coming into view 45-130 m
                                          # off it: probation.track_reach). None: off
    moved_beyond_own_gate: bool = False   # a young landmark 'moves' only to a sighting beyond
                                          # its own gate: one in its grey zone (or refused by
                                          # the joint test) is dropped (LandmarkManager)

    def yaw_fix_sigma_rad(self, dt_s: float | None) -> float:
        """The sigma to fuse one autopilot yaw sample with, ``dt_s`` after the last one (None:
        the first), when its error is white noise plus a bias correlated over ``yaw_bias_tau_s``.

        As for position fixes (README): n samples sharing one bias carry together about one
        bias-sigma of information, so each is fused at sqrt(white^2 + bias^2 n), with n = tau /
        dt, or fewer when the gyro makes the filter forget sooner. A random-walk yaw (gyro
        variance q per sample, the yaw rate's Q) fused at variance r >> q settles at P = sqrt(q r)
        with a gain of sqrt(q / r); its true error is then the bias (bias^2) plus the gyro drift
        the gain lets through (q / 2 gain = P / 2). P = bias^2 + P / 2 gives P = 2 bias^2, so r =
        4 bias^4 / q: n = 4 bias^2 / q. With a gyro better than its Q the true error is nearer
        bias^2 alone (the filter errs on the cautious side); fused as white noise (n = 1) the
        filter would claim sqrt(q) white, a fraction of the bias.
        """
        white, bias = self.yaw_sigma_rad, self.yaw_bias_sigma_rad
        if bias <= 0.0:
            return white
        if dt_s is None or dt_s <= 0.0:
            return math.hypot(white, bias)          # one look: off by the whole bias
        b2 = bias * bias
        samples = self.yaw_bias_tau_s / dt_s
        q = (self.velocity_noise.yaw_rate_sigma_rad_s * dt_s) ** 2
        if q > 0.0:
            samples = min(samples, 4.0 * b2 / q)
        return math.sqrt(white * white + b2 * max(1.0, samples))

    def __post_init__(self) -> None:
        if self.motion_model not in MOTION_MODELS:
            raise ValueError(f"unknown motion model {self.motion_model!r}")
        if self.degraded_reaction not in REACTIONS or self.lost_reaction not in REACTIONS:
            raise ValueError(f"reactions are one of {REACTIONS}")


def moderate(command: GuidanceCommand, health: Consistency, options: EstimatorOptions,
             yaw_rad: float) -> GuidanceCommand:
    """Arrival only with the pose known well enough; the configured reaction to bad health.

    'arrival_uncertain': inside the goal radius but the pose's 2-sigma radius exceeds the arrival
    tolerance: hold there (speed 0) and say so, do not declare arrival. Degraded or lost: the
    configured reaction, 'slow' (speed x slow_factor) or 'hold' (speed 0 at the current yaw).
    """
    if command.mode == "arrived":
        if health.radius_2sigma_m > options.arrival_tolerance_m:
            return replace(command, mode="arrival_uncertain")
        return command
    reaction = {"degraded": options.degraded_reaction,
                "lost": options.lost_reaction}.get(health.state, "none")
    if reaction == "hold":
        return replace(command, speed_mps=0.0, heading_rad=yaw_rad,
                       mode=f"hold: estimator {health.state}")
    if reaction == "slow":
        return replace(command, speed_mps=command.speed_mps * options.slow_factor)
    return command
