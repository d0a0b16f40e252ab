"""The filter's range-dependent R: a stereo camera's range error grows with the square of the range.

Stereo depth is z = f B / d (focal length f in pixels, baseline B in metres, disparity d in
pixels); an error of sigma_d pixels in the disparity gives sigma_z = z^2 sigma_d / (f B), so
sigma_r(r) = floor + k r^2 with k = sigma_d / (f B) (Intel's D400 tuning and subpixel papers).
This is the filter's model, configured apart from the truth camera's (``estimator.range_sigma_m``
is the floor, ``estimator.range_sigma_k_per_m`` the k) so that a mismatch can be studied.

R is built per observation from the *measured* range (the filter does not know the true one; at
the association stage it does not yet know which landmark either): the measured range's own error
makes sigma_r off by about 2 k r of itself per sigma of that error (k = 0.0015 /m: 3% at 10 m,
12% at 40 m). An observation that already carries its own R (a depth camera's blob) keeps it.

That error is not harmless: a range measured short gets a smaller sigma, so more weight, than
one measured long by as much. Weighted by 1/sigma^2 ~ r^-4, many sightings of one trunk average
to a range short by about 4 sigma_r^2 / r (7 cm at 20 m), the trunks are mapped toward the
points they were seen from, and the pose, localised against them, drifts while its covariance
shrinks: in the dense forest (20 trunks a frame) the pose NEES rose from 2 to 10-17 over a
100 s flight, with perfect association as well (docs/forest.md, "The range sigma's bias").
``estimator.range_sigma_at: predicted`` (EkfSlam.set_range_model) evaluates the model again at
the update, at the landmark's predicted range, which does not share the sighting's error; the
measured range's R stays for the association's gates and for starting a landmark, where no
prediction exists.
"""
from __future__ import annotations

import dataclasses
from typing import Sequence

from companion.core.estimation.slam_types import Observation


def stereo_range_sigma_m(range_m: float, floor_m: float, k_per_m: float) -> float:
    """sigma_r = floor + k r^2, metres."""
    return floor_m + k_per_m * range_m * range_m


def stereo_k_per_m(disparity_sigma_px: float, focal_length_px: float, baseline_m: float) -> float:
    """k of sigma_r = k r^2 from a stereo camera's figures, per metre."""
    return disparity_sigma_px / (focal_length_px * baseline_m)


def with_range_model(observations: Sequence[Observation], floor_m: float, k_per_m: float,
                     bearing_sigma_rad: float) -> list[Observation]:
    """The observations, each without an R of its own given R = diag(sigma_r(r)^2, sigma_b^2).
    k = 0: returned as they are (the filter's constant R applies)."""
    if k_per_m <= 0.0:
        return list(observations)
    bearing_var = bearing_sigma_rad * bearing_sigma_rad
    out = []
    for obs in observations:
        if obs.meas_cov is None:
            sigma = stereo_range_sigma_m(obs.range_m, floor_m, k_per_m)
            obs = dataclasses.replace(obs, meas_cov=((sigma * sigma, 0.0), (0.0, bearing_var)),
                                      range_modelled=True)
        out.append(obs)
    return out
