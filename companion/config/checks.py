"""Plausibility bounds and the value checks several config sections share."""
from __future__ import annotations

import math

from companion.config.loader import require


PLAUSIBLE_SPEED_MPS = 50.0        # faster is no multicopter (the pipeline refuses such odometry)
PLAUSIBLE_ACCEL_MPS2 = 20.0      # 2 g sideways: far beyond any multicopter's ANGLE_MAX
PLAUSIBLE_DELAY_S = 10.0
PLAUSIBLE_JERK_MPS3 = 100.0       # PSC_JERK_XY's range is 1 to 20 m/s/s/s
MAX_STEREO_K_PER_M = 1.0     # sigma_r = k r^2: at k = 1 /m the range is noise beyond 1 m


def require_positive(key: str, value: float) -> None:
    require(value > 0.0, key, value, "a value > 0")


def require_sigma(key: str, value: float) -> None:
    require(value > 0.0, key, value,
            "a standard deviation > 0 (the covariance must be positive definite)")


def require_stereo_k(key: str, value: float) -> None:
    require(0.0 <= value <= MAX_STEREO_K_PER_M, key, value,
            f"a coefficient in [0, {MAX_STEREO_K_PER_M}] per metre (sigma_r = k r^2; a stereo "
            "camera's k = disparity sigma px / (focal length px x baseline m), about 0.0015)")


def view_yaws_rad(yaws_deg: tuple[float, ...]) -> tuple[float, ...]:
    """A camera rig's yaws on the body, degrees (config) to radians (core); [0] stays (0.0,)."""
    return tuple(math.radians(v) for v in yaws_deg)
