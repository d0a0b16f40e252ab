"""Estimator timings: predict, update, a predict-plus-ten-updates step, against the floor and
the dense textbook filter (tests/core/dense_reference.py, the correctness oracle)."""
from __future__ import annotations

import math
import time

import numpy as np

from companion.core.ekf_slam import AssociationGates, EkfSlam, Observation, SlamNoise
from companion.core.geometry import observe
from tests.core.dense_reference import DenseEkfSlam

NOISE = SlamNoise(0.3, math.radians(0.02), 0.1, 0.1, math.radians(0.5))


def median_us(fn, reps: int) -> float:
    times = []
    for _ in range(reps):
        start = time.perf_counter()
        fn()
        times.append(time.perf_counter() - start)
    return float(np.median(times) * 1e6)


def build(landmarks: int, seed: int = 0) -> tuple[EkfSlam, np.ndarray]:
    """A filter with ``landmarks`` mapped landmarks scattered 5 to 200 m around the vehicle."""
    rng = np.random.default_rng(seed)
    slam = EkfSlam(np.zeros(3), np.eye(3) * 0.01, NOISE, AssociationGates(outlier_nis=1e12, pose_correction_nis=1e12))
    bearings = rng.uniform(-math.pi, math.pi, landmarks)
    ranges = rng.uniform(5.0, 200.0, landmarks)
    for i in range(landmarks):
        slam.update(Observation(ranges[i], bearings[i], i))
    return slam, slam.landmarks()


def measure(landmarks: int, reps: int) -> dict:
    slam, truth = build(landmarks)
    rng = np.random.default_rng(1)

    def one_update(index: int, with_id: bool) -> None:
        z = observe(slam.pose, truth[index]) + rng.normal(0.0, [0.05, 0.001])
        slam.update(Observation(z[0], z[1], index if with_id else None))

    predict_us = median_us(lambda: slam.predict(1.0, 0.001, 0.1), reps * 4)
    update_us = median_us(lambda: one_update(int(rng.integers(landmarks)), True), reps)

    n = slam.mean.size
    cov = slam.cov.copy()
    a, b = rng.normal(size=(n, 2)), rng.normal(size=(n, 2))

    def floor() -> None:                        # the bare in-place rank-2 update
        cov.__isub__(a @ b.T)
    floor_us = median_us(floor, reps)

    dense = DenseEkfSlam(slam.pose, slam.pose_cov, NOISE.speed_sigma_mps,
                         NOISE.heading_change_sigma_rad, NOISE.reference_dt_s,
                         NOISE.range_sigma_m, NOISE.bearing_sigma_rad)
    dense.x, dense.P = slam.mean.copy(), slam.cov.copy()
    dense_us = median_us(lambda: dense.update(observe(dense.x[:3], truth[3]), 3),
                         max(3, reps // 20 if landmarks > 100 else reps // 4))

    # Last, on a fresh filter: id-less reports can start new landmarks when association fails,
    # and a growing map must not leak into the other figures (it once tripled them).
    slam, truth = build(landmarks)

    def step10() -> None:                       # association by gated nearest neighbour
        slam.predict(0.0, 0.0, 0.1)             # hovering: the map stays where it is
        for index in rng.choice(landmarks, size=min(10, landmarks), replace=False):
            one_update(int(index), False)
    step10_us = median_us(step10, max(reps // 4, 5))
    step10_landmarks_after = slam.landmark_count
    return {"landmarks": landmarks, "predict_us": predict_us, "update_us": update_us,
            "step10_us": step10_us, "step10_landmarks_after": step10_landmarks_after,
            "floor_rank2_us": floor_us, "dense_update_us": dense_us}


def run(quick: bool) -> list[dict]:
    reps = 40 if quick else 200
    return [measure(n, reps) for n in (10, 50, 100, 200, 500)]
