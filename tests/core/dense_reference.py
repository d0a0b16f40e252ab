"""A plain, dense, textbook EKF-SLAM: the correctness oracle for companion.core.estimation.ekf_slam.

Deliberately naive: full Jacobians F and H over the whole state, K = P H^T S^-1, and the Joseph
update (I - K H) P (I - K H)^T + K R K^T, all as dense products. Slow (O(n^3)) and obviously right.
benchmarks/run.py times its update as ``dense_update_us``.
"""
from __future__ import annotations

import math

import numpy as np


def wrap(a):
    return (a + math.pi) % (2 * math.pi) - math.pi


class DenseEkfSlam:
    def __init__(self, pose, pose_cov, speed_sigma, heading_sigma, ref_dt, range_sigma, bearing_sigma):
        self.x = np.array(pose, dtype=float)
        self.P = np.array(pose_cov, dtype=float)
        self.speed_sigma, self.heading_sigma, self.ref_dt = speed_sigma, heading_sigma, ref_dt
        self.R = np.diag([range_sigma ** 2, bearing_sigma ** 2])

    def predict(self, v, g, dt):
        n = len(self.x)
        psi = self.x[2]
        F = np.eye(n)
        F[0, 2] = -v * dt * math.sin(psi + g)
        F[1, 2] = v * dt * math.cos(psi + g)
        G = np.zeros((n, 2))
        G[0] = [dt * math.cos(psi + g), -v * dt * math.sin(psi + g)]
        G[1] = [dt * math.sin(psi + g), v * dt * math.cos(psi + g)]
        G[2] = [0.0, 1.0]
        Q = np.diag([self.speed_sigma ** 2, self.heading_sigma ** 2 * dt / self.ref_dt])
        self.x[0] += v * dt * math.cos(psi + g)
        self.x[1] += v * dt * math.sin(psi + g)
        self.x[2] = wrap(psi + g)
        self.P = F @ self.P @ F.T + G @ Q @ G.T

    def add(self, z):
        x, y, psi = self.x[:3]
        r, b = z
        m = [x + r * math.cos(psi + b), y + r * math.sin(psi + b)]
        n = len(self.x)
        Gv = np.array([[1, 0, -r * math.sin(psi + b)], [0, 1, r * math.cos(psi + b)]])
        Gz = np.array([[math.cos(psi + b), -r * math.sin(psi + b)],
                       [math.sin(psi + b), r * math.cos(psi + b)]])
        J = np.zeros((n + 2, n + 2))     # the full augmentation Jacobian
        J[:n, :n] = np.eye(n)
        J[n:, :3] = Gv
        Rbig = np.zeros((n + 2, n + 2))
        Rbig[n:, n:] = Gz @ self.R @ Gz.T
        Pbig = np.zeros((n + 2, n + 2))
        Pbig[:n, :n] = self.P
        self.x = np.concatenate([self.x, m])
        self.P = J @ Pbig @ J.T + Rbig

    def update(self, z, j):
        n = len(self.x)
        s0 = 3 + 2 * j
        dx, dy = self.x[s0] - self.x[0], self.x[s0 + 1] - self.x[1]
        q = dx * dx + dy * dy
        r = math.sqrt(q)
        H = np.zeros((2, n))
        H[:, :3] = [[-dx / r, -dy / r, 0], [dy / q, -dx / q, -1]]
        H[:, s0:s0 + 2] = [[dx / r, dy / r], [-dy / q, dx / q]]
        nu = np.array([z[0] - r, wrap(z[1] - (math.atan2(dy, dx) - self.x[2]))])
        S = H @ self.P @ H.T + self.R
        K = self.P @ H.T @ np.linalg.inv(S)
        self.x = self.x + K @ nu
        self.x[2] = wrap(self.x[2])
        I_KH = np.eye(n) - K @ H
        self.P = I_KH @ self.P @ I_KH.T + K @ self.R @ K.T
