"""The paper's Figure 4 as a PNG: true and estimated paths, obstacles, safety circles, the map.

Axes: north (m) horizontal and east (m) vertical, so the paper's (x, y) read directly.
"""
from __future__ import annotations

from pathlib import Path

import numpy as np


def pyplot():
    """matplotlib.pyplot on the Agg backend (PNG files, no display): the package's one set-up."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    return plt


def covariance_ellipse(mean: np.ndarray, cov: np.ndarray, sigmas: float = 3.0,
                       points: int = 48) -> np.ndarray:
    """Points (points, 2) of the ``sigmas`` ellipse of a 2D Gaussian."""
    values, vectors = np.linalg.eigh(0.5 * (cov + cov.T))
    radii = sigmas * np.sqrt(np.clip(values, 0.0, None))
    angles = np.linspace(0.0, 2.0 * np.pi, points)
    circle = np.stack([np.cos(angles), np.sin(angles)], axis=1)
    return mean + (circle * radii) @ vectors.T


def offset_outline(corners: np.ndarray, distance_m: float, arc_points: int = 8) -> np.ndarray:
    """The closed outline (k, 2) of the points ``distance_m`` from a convex polygon (m, 2),
    counter-clockwise: each edge pushed out, the corners rounded."""
    corners = np.asarray(corners, dtype=float)
    edges = np.roll(corners, -1, axis=0) - corners
    normals = np.column_stack((edges[:, 1], -edges[:, 0])) / np.hypot(*edges.T)[:, None]
    out = []
    for i, corner in enumerate(corners):
        a0 = np.arctan2(*normals[i - 1][::-1])
        a1 = np.arctan2(*normals[i][::-1])
        a1 = a0 + (a1 - a0) % (2.0 * np.pi)
        for a in np.linspace(a0, a1, arc_points):
            out.append(corner + distance_m * np.array([np.cos(a), np.sin(a)]))
    out.append(out[0])
    return np.array(out)


def plot_paths(path: str | Path, *, true_ne: np.ndarray, est_ne: np.ndarray,
               obstacles_ne: np.ndarray, obstacle_radii: np.ndarray, safety_distance_m: float,
               goal_ne: np.ndarray, landmarks_ne: np.ndarray, landmark_covs: np.ndarray,
               title: str, start_ne: np.ndarray | None = None,
               shapes_ne: list[np.ndarray] = ()) -> None:
    """Draw the flight; every array is (k, 2) [north_m, east_m]; ``shapes_ne`` the walls' and
    buildings' outlines (m, 2) each, drawn filled with their safety distance around them."""
    plt = pyplot()
    fig, ax = plt.subplots(figsize=(10, 4.8), dpi=110)
    if len(true_ne):
        ax.plot(true_ne[:, 0], true_ne[:, 1], "b-", lw=1.6, label="true path")
    if len(est_ne):
        ax.plot(est_ne[:, 0], est_ne[:, 1], "r--", lw=1.3, label="estimated path")
    for i, (centre, radius) in enumerate(zip(obstacles_ne, obstacle_radii)):
        ax.add_patch(plt.Circle(tuple(centre), radius, color="green", alpha=0.35))
        ax.add_patch(plt.Circle(tuple(centre), safety_distance_m, fill=False, ls=":", color="green",
                                label="safety distance d" if i == 0 else None))
    if len(obstacles_ne):
        ax.plot(obstacles_ne[:, 0], obstacles_ne[:, 1], "g*", ms=11, label="obstacle centre")
    for i, corners in enumerate(shapes_ne):
        ax.add_patch(plt.Polygon(corners, closed=True, color="saddlebrown", alpha=0.5,
                                 label="wall / building" if i == 0 else None))
        ring = offset_outline(corners, safety_distance_m)
        ax.plot(ring[:, 0], ring[:, 1], ":", color="saddlebrown", lw=0.9)
    for i, (mean, cov) in enumerate(zip(landmarks_ne, landmark_covs)):
        ring = covariance_ellipse(mean, cov)
        ax.plot(ring[:, 0], ring[:, 1], "k-", lw=0.8, label="landmark 3-sigma" if i == 0 else None)
    if len(landmarks_ne):
        ax.plot(landmarks_ne[:, 0], landmarks_ne[:, 1], "k+", ms=9, label="estimated landmark")
    ax.plot([goal_ne[0]], [goal_ne[1]], "mh", ms=13, label="goal")
    if start_ne is not None:
        ax.plot([start_ne[0]], [start_ne[1]], "bo", ms=6, label="start")
    ax.set_xlabel("north (m)")
    ax.set_ylabel("east (m)")
    ax.set_aspect("equal", adjustable="datalim")
    ax.grid(True, alpha=0.3)
    ax.set_title(title)
    ax.legend(loc="best", fontsize=8)
    fig.tight_layout()
    fig.savefig(path)
    plt.close(fig)


def plot_run(path: str | Path, scenario, outcome, title: str) -> None:
    """Plot one ``companion simulate`` run."""
    world = scenario.world
    plot_paths(
        path,
        true_ne=np.array(outcome.trace.true_pose).reshape(-1, 3)[:, :2],
        est_ne=np.array(outcome.trace.est_pose).reshape(-1, 3)[:, :2],
        obstacles_ne=outcome.obstacles,
        obstacle_radii=np.array([o.radius_m for o in world.obstacles]),
        safety_distance_m=scenario.safety_distance_m,
        goal_ne=np.array([world.goal.north_m, world.goal.east_m]),
        landmarks_ne=outcome.landmarks, landmark_covs=outcome.landmark_covs,
        title=title, start_ne=np.array([world.start.north_m, world.start.east_m]),
        shapes_ne=[shape.corners_ne() for _, shape in world.shapes()])
