"""Data association without ids for one camera frame: gated nearest neighbour, jointly checked.

Every observation of the frame is scored against every landmark first (NIS, 2 dof), then pairs
are taken in ascending NIS (global nearest neighbour: the closest pair wins, whatever the order
the camera listed its detections in), each landmark and each observation at most once. The
pairing is then checked as a whole: the stacked innovation against the joint S, which holds the
observations' correlation through the shared pose, must lie within the chi-square gate of 2K dof
(joint compatibility); while it does not, the least likely pair is dropped. An observation left
without a landmark is new only if it gated on none, taken or not: one that would have gated on a
landmark another observation took is ambiguous, not a new landmark beside it.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from companion.core.estimation.consistency import chi2_quantile
from companion.core.estimation.ekf_slam import EkfSlam

JOINT_PROBABILITY = 0.999


@dataclass(frozen=True)
class Pairing:
    """What to do with one observation: 'update' landmark ``index``, 'ambiguous' (``index`` the
    landmark it came near), or 'new' (it gated on no landmark); ``nis`` against ``index``."""
    action: str
    index: int | None
    nis: float | None


def associate_frame(slam: EkfSlam, z: np.ndarray, joint_probability: float = JOINT_PROBABILITY,
                    meas_covs: list | None = None) -> list[Pairing]:
    """Pairings for the observations z (K, 2) [range_m, bearing_rad] against the map's landmarks.
    ``meas_covs``: each observation's R (2,2) or None (the filter's)."""
    k_obs, n = len(z), slam.landmark_count
    if n == 0:
        return [Pairing("new", None, None) for _ in range(k_obs)]
    gates = slam.gates
    covs = meas_covs if meas_covs is not None else [None] * k_obs
    nis = np.array([slam.nis_all(z[k], covs[k])[0] for k in range(k_obs)]).reshape(k_obs, n)
    assigned: dict[int, int] = {}
    taken: set[int] = set()
    for flat in np.argsort(nis, axis=None, kind="stable"):
        k, i = divmod(int(flat), n)
        if nis[k, i] > gates.accept_nis:
            break
        if k in assigned or i in taken:
            continue
        assigned[k] = i
        taken.add(i)
    refused: set[int] = set()
    while assigned:
        obs = sorted(assigned)
        joint = slam.joint_nis(z[obs], [assigned[k] for k in obs], _stack(covs, obs, slam))
        if joint <= chi2_quantile(joint_probability, 2 * len(obs)):
            break
        worst = max(obs, key=lambda k: nis[k, assigned[k]])
        refused.add(worst)
        del assigned[worst]
    out = []
    for k in range(k_obs):
        if k in assigned:
            out.append(Pairing("update", assigned[k], float(nis[k, assigned[k]])))
            continue
        best = int(np.argmin(nis[k]))
        if k in refused or nis[k, best] <= gates.new_landmark_nis:
            out.append(Pairing("ambiguous", best, float(nis[k, best])))
        else:
            out.append(Pairing("new", None, float(nis[k, best])))
    return out


def _stack(covs: list, obs: list[int], slam: EkfSlam) -> np.ndarray | None:
    """The R of observations ``obs`` as (K, 2, 2); None when every one is the filter's."""
    if all(covs[k] is None for k in obs):
        return None
    default = slam.noise.measurement_cov()
    return np.array([default if covs[k] is None else covs[k] for k in obs])
