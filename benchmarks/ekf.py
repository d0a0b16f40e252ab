"""Estimator timings: predict, update, a predict-plus-ten-updates step, a camera frame of ten
observations (sequential and batched), against their floors and the dense textbook filter
(tests/core/dense_reference.py, the correctness oracle).

The floor of an update is the cheapest correct in-place update of the same rank: the one BLAS
call the update itself makes (EkfSlam._joseph_rows: dgemm, P -= U (U M)^T with U = P H^T, inner
dimension 2 for the rank-2 Joseph correction of one range-bearing observation), alone, on the
filter's own matrix. A frame of K observations is measured against the floor of one rank-2K pass
(the same call with inner dimension 2K), which is what EkfSlam.update_batch makes. (Until
2026-12-02 the correction was written P -= [K B][B K]^T, inner dimension 4 and 4K, and so was the
floor: for one observation, where the pass is bound by memory, a few us dearer than inner 2; for a
frame of 10, where it is bound by arithmetic, twice the time.)
"""
from __future__ import annotations

import math
import time

import numpy as np
from scipy.linalg.blas import dgemm

from companion.core.estimation.ekf_slam import EkfSlam
from companion.core.estimation.slam_types import (AssociationGates, LANDMARK_DIM, Observation,
                                                  SlamNoise)
from companion.core.geometry import observe
from tests.core.dense_reference import DenseEkfSlam

NOISE = SlamNoise(0.3, math.radians(0.02), 0.1, 0.1, math.radians(0.5))
FRAME_OBSERVATIONS = 10


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

    def prepared_update():
        index = int(rng.integers(landmarks))
        z = observe(slam.pose, truth[index]) + rng.normal(0.0, [0.05, 0.001])
        obs = Observation(z[0], z[1], index)
        return lambda: slam.update(obs)

    predict_us = median_us(lambda: slam.predict(1.0, 0.001, 0.1), reps * 4)
    # the update and its floor interleaved call by call on the same matrix, so a change of
    # the machine's load while they run weighs on both (drawing the observation: untimed)
    update_us, floor_us = paired_us(prepared_update, floor_call(slam, 1, rng), reps * 25)
    k = min(FRAME_OBSERVATIONS, landmarks)

    def frame(batched: bool):
        ids = rng.choice(landmarks, size=k, replace=False)
        observations = []
        for index in ids:
            z = observe(slam.pose, truth[index]) + rng.normal(0.0, [0.05, 0.001])
            observations.append(Observation(z[0], z[1], int(index)))
        return lambda: slam.update_batch(observations) if batched else \
            slam.update_frame(observations)

    frame_sequential_us = median_prepared_us(lambda: frame(False), reps)
    frame_batch_us, frame_floor_us = paired_us(lambda: frame(True), floor_call(slam, k, rng),
                                               reps * 5)

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
            "floor_us": floor_us, "dense_update_us": dense_us, "frame_observations": k,
            "frame_sequential_us": frame_sequential_us, "frame_batch_us": frame_batch_us,
            "frame_floor_us": frame_floor_us}


def floor_call(slam: EkfSlam, observations: int, rng):
    """The update's own BLAS call alone, for a rank-2K correction (K observations), on the
    filter's own covariance (the same matrix, the same memory, updated in place through its
    transpose as EkfSlam._joseph_pass does, with the same positional call), with
    Fortran-ordered (N, 2K) operands as the update passes them (C-ordered ones would make dgemm
    copy them: a slower, false floor). Signs alternate, so two calls put the matrix back (to
    rounding: the operands are 1e-3, their products 1e-6) and the filter stays as it was."""
    cov = slam._cov_buf
    n, width = cov.shape[0], LANDMARK_DIM * observations
    left = np.asfortranarray(rng.normal(size=(n, width)) * 1e-3)
    right = np.asfortranarray(rng.normal(size=(n, width)) * 1e-3)
    sign = [1.0]

    def call() -> None:
        sign[0] = -sign[0]
        dgemm(sign[0], right, left, 1.0, cov.T, 0, 1, 1)
    return call


def floor_of(slam: EkfSlam, observations: int, reps: int, rng) -> float:
    """Median of :func:`floor_call` alone."""
    return median_us(floor_call(slam, observations, rng), reps)


def paired_us(prepare, floor, reps: int) -> tuple[float, float]:
    """Medians of ``prepare()()`` (preparing untimed) and of ``floor()``, interleaved call by
    call: each repeat times the update once, then the floor twice (its two signs: the matrix is
    put back). Whatever the machine's load does while they run weighs on both alike, so their
    ratio holds on a busy machine where each figure alone moves by a third."""
    times, floor_times = [], []
    clock = time.perf_counter
    for _ in range(reps):
        fn = prepare()
        start = clock()
        fn()
        times.append(clock() - start)
        for _ in range(2):
            start = clock()
            floor()
            floor_times.append(clock() - start)
    return float(np.median(times) * 1e6), float(np.median(floor_times) * 1e6)


def median_prepared_us(prepare, reps: int) -> float:
    """Median of ``prepare()()`` timings, preparing (drawing the observations) untimed."""
    times = []
    for _ in range(reps):
        fn = prepare()
        start = time.perf_counter()
        fn()
        times.append(time.perf_counter() - start)
    return float(np.median(times) * 1e6)


def run(quick: bool) -> list[dict]:
    reps = 40 if quick else 200
    return [measure(n, reps) for n in (10, 50, 100, 200, 500)]
