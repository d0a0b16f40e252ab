"""A stereo depth camera's error model (ALGORITHM-NOTES "Depth cameras"), pure maths.

Intel's RMS depth error of a D4xx: sigma_z = z^2 x subpixel / (fx x baseline), with fx the focal
length in pixels of the depth image, the baseline in metres and the subpixel RMS of the disparity
in pixels (about 0.08). A D455 at 848 px (fx ~447, 95 mm): 7.5 mm at 2 m, 30 mm at 4 m.
"""
from __future__ import annotations

import numpy as np


def stereo_sigma_z_m(z_m, fx_px: float, baseline_m: float, subpixel_px: float):
    """The RMS depth error at depth ``z_m`` (a float or an array, metres), in metres."""
    return np.square(z_m) * (subpixel_px / (fx_px * baseline_m))


def disparity_px(z_m, fx_px: float, baseline_m: float):
    """The disparity of a point at depth ``z_m`` (0 where z is infinite), pixels."""
    with np.errstate(divide="ignore"):
        return (fx_px * baseline_m) / np.asarray(z_m, dtype=float)
