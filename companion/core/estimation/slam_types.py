"""The filter's value types: its noise (Q, R), its association gates, an observation, an update's
report. Apart from the filter (ekf_slam.py) so that the codecs, the config and the perception code
name an observation or a noise without importing the filter.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

POSE_DIM = 3
LANDMARK_DIM = 2


@dataclass(frozen=True)
class SlamNoise:
    """Q and R of the filter.

    Q: odometry noise, ``speed_sigma_mps`` per speed sample and ``heading_change_sigma_rad`` per
    ``reference_dt_s`` of heading change (it accumulates: variance scales with dt).
    R: ``range_sigma_m`` and ``bearing_sigma_rad`` per observation.
    """
    speed_sigma_mps: float
    heading_change_sigma_rad: float
    reference_dt_s: float
    range_sigma_m: float
    bearing_sigma_rad: float

    def measurement_cov(self) -> np.ndarray:
        """R, (2,2)."""
        return np.diag([self.range_sigma_m ** 2, self.bearing_sigma_rad ** 2])


@dataclass(frozen=True)
class VelocityNoise:
    """Q of the multicopter model, per odometry sample (a sample's error is held over its dt):
    the autopilot's NED velocity on each axis and its yaw rate."""
    vel_north_sigma_mps: float
    vel_east_sigma_mps: float
    yaw_rate_sigma_rad_s: float


def chi2_2dof_quantile(p: float) -> float:
    """Chi-square quantile for 2 degrees of freedom, exactly: the CDF is 1 - exp(-x/2).

    Written out so the daemon need not import scipy.stats (about 40 MB and 0.7 s of start-up).
    """
    return -2.0 * math.log1p(-p)


@dataclass(frozen=True)
class AssociationGates:
    """Gates on the normalised innovation squared (chi-square, 2 degrees of freedom).

    An observation with NIS <= ``accept_nis`` against its nearest landmark updates it; one whose
    NIS exceeds ``new_landmark_nis`` against every landmark starts a new one; in between it is
    ambiguous and dropped. ``outlier_nis`` rejects an id-associated observation that disagrees
    grossly with its landmark (a glitch, or a mover). ``pose_correction_nis``: an id-associated
    observation beyond it (but within ``outlier_nis``) corrects its landmark only, never the pose:
    no single update moves the pose further than the acceptance gate allows (None: accept_nis).
    """
    accept_nis: float = chi2_2dof_quantile(0.99)
    new_landmark_nis: float = chi2_2dof_quantile(0.99999)
    outlier_nis: float = chi2_2dof_quantile(0.99999)
    pose_correction_nis: float | None = None

    @property
    def pose_nis(self) -> float:
        return self.accept_nis if self.pose_correction_nis is None else self.pose_correction_nis

    def __post_init__(self) -> None:
        if not 0.0 < self.accept_nis <= self.new_landmark_nis:
            raise ValueError("gates must satisfy 0 < accept_nis <= new_landmark_nis")


@dataclass(frozen=True)
class Observation:
    """One range-bearing observation of an obstacle centre, bearing from the heading, right positive.

    ``meas_cov``: this observation's own R, ((var_r, cov), (cov, var_b)) in m^2, m rad, rad^2
    (a landmark made from a depth camera's sectors knows its spread); None: the filter's R.
    ``range_modelled``: ``meas_cov`` is not the observation's own but the filter's stereo model
    evaluated at the measured range (core/estimation/range_noise.py), which an update may
    evaluate again at the landmark's predicted range (EkfSlam.set_range_model).
    ``top_down_m`` / ``bottom_down_m``: the highest and lowest of its points, as depths below the
    camera (FRD z, down positive; core/perception/vertical_extent.py); None: a 2D observation. The EKF
    itself never reads them. ``top_clipped`` / ``bottom_clipped``: the camera saw the obstacle
    reach its image's upper / lower edge (a depth image's points, perception/depth_obstacles.py),
    so that bound is not the obstacle's, whatever the geometry of a level view says.
    """
    range_m: float
    bearing_rad: float
    obstacle_id: int | None = None
    meas_cov: tuple | None = None
    top_down_m: float | None = None
    bottom_down_m: float | None = None
    range_modelled: bool = False
    top_clipped: bool = False
    bottom_clipped: bool = False

    def meas_cov_array(self) -> np.ndarray | None:
        return None if self.meas_cov is None else np.asarray(self.meas_cov, dtype=float)


@dataclass(frozen=True)
class UpdateReport:
    """What one update did. ``action``, from the filter (ekf_slam.py): 'updated', 'added',
    'ambiguous', 'outlier' (a landmark observation refused by its gate; also a refused position
    fix), 'position' (a position fix fused), 'yaw' and 'yaw_reset' (the autopilot's yaw fused,
    or taken after a jump); from the landmark manager (landmark_manager.py): 'ambiguous' (also
    an observation its frame's association left unpaired), 'moved' (a young landmark seen where
    it moved to), 'deleted' and 'expired' (the lifecycle's removals), 'archived' (a landmark
    behind and unseen moved to the bounded map's archive); from mover probation
    (probation.py): 'mover' (a track updated), 'mover_detected' (a landmark demoted to a
    track), 'expired' (a young mover's coasting out)."""
    action: str
    landmark_index: int | None
    innovation: tuple[float, float] | None
    nis: float | None
    obstacle_id: int | None
