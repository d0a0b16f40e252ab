"""How well the depth perception places trunks, frame by frame, on rendered random forests
(issue 44): the fast loop before flying 100 forests (benchmarks/depth_forest_frames.py prints it;
tests/sim/test_depth_forest_heldout.py holds it on cameras and trunks the project has not seen).

Frames: the camera of ``depth`` (D455 errors on) on ``mount``, rendered from poses along each
forest's leg (north 5 to 180 m, east within 3 m of the line, 10 m up, heading north with 10 deg
of yaw noise and 2 deg of roll and pitch), perceived by ``perceive`` with the tilt known (as
ATTITUDE gives it). Each observation is matched to the nearest trunk centre, in the level frame
along the heading; the camera's offset on the body is in the error.
"""
from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass

import numpy as np

from companion.config.depth import DepthConfig
from companion.config.scenario import Scenario
from companion.core.perception.blobs import SurfacePoint
from companion.core.perception.depth_frame import CameraMount, DepthFrame
from companion.core.perception.depth_perception import DepthPerceptionParams, perceive
from companion.sim.depth_camera import TruePose, render_true_m, scene_of
from companion.sim.depth_render import DepthRenderer, ErrorModel, StereoErrors
from companion.sim.forest_worlds import FOREST_SPECS, forest_world

RANGE_BANDS_M = ((0.0, 8.0), (8.0, 12.0), (12.0, 16.0), (16.0, 30.0))
FOUND_M = 0.3          # a trunk in view is found when a post lies this near its centre
IN_VIEW_M = 12.0       # ... counted for trunks this near, away from the view's edges


@dataclass(frozen=True)
class FrameQuality:
    """Over the frames: observations per frame; the share that are surface (chain) points; the
    posts' centre errors per range band (RANGE_BANDS_M: median, p90, signed range bias; NaN
    where none); of the trunks within IN_VIEW_M in view, the share with a post within FOUND_M;
    the largest range sigma of a chain point within 16 m (its spread included)."""
    frames: int
    observations_per_frame: float
    chain_share: float
    post_median_m: tuple
    post_p90_m: tuple
    post_range_bias_m: tuple
    posts: tuple
    found_share: float
    max_chain_sigma_near_m: float


def _level_trees(world, pose: TruePose) -> np.ndarray:
    c = np.array([[o.north_m - pose.north_m, o.east_m - pose.east_m] for o in world.obstacles])
    cy, sy = math.cos(pose.yaw_rad), math.sin(pose.yaw_rad)
    return np.column_stack((cy * c[:, 0] + sy * c[:, 1], -sy * c[:, 0] + cy * c[:, 1]))


def frame_quality(base: Scenario, params: DepthPerceptionParams, depth: DepthConfig,
                  mount: CameraMount, worlds: int = 2, frames: int = 20, seed: int = 0,
                  kind: str = "forest", radius_m: tuple | None = None) -> FrameQuality:
    """The perception's quality on ``frames`` frames of each of ``worlds`` forests (``kind``,
    seeds from ``seed``; trunk radii ``radius_m`` instead of the generator's if given)."""
    spec = FOREST_SPECS[kind]
    if radius_m is not None:
        spec = dataclasses.replace(spec, radius_m=tuple(radius_m))
    drawn = [forest_world(base, seed + w, kind, spec).world for w in range(worlds)]
    intr = depth.intrinsics()
    renderer, errors = DepthRenderer(intr), ErrorModel(intr, StereoErrors.of(depth))
    rng = np.random.default_rng([seed, 0xF4A3E])
    posts, chain, count, seen, found = [], 0, 0, 0, 0
    chain_sigma = 0.0
    for world in drawn:
        scene = scene_of(world, 0.0)
        for _ in range(frames):
            pose = TruePose(float(rng.uniform(5.0, 180.0)), float(rng.uniform(-3.0, 3.0)), 10.0,
                            float(rng.normal(0.0, math.radians(2.0))),
                            float(rng.normal(0.0, math.radians(2.0))),
                            float(rng.normal(0.0, math.radians(10.0))))
            pixels = errors(render_true_m(renderer, scene, pose, mount), rng)
            percept = perceive(DepthFrame(0, 0, 0, intr, pixels), mount, pose.roll_rad,
                               pose.pitch_rad, pose.alt_m, params)
            trees = _level_trees(world, pose)
            count += len(percept.observations)
            post_xy = []
            for obs in percept.observations:
                xy = obs.range_m * np.array([math.cos(obs.bearing_rad), math.sin(obs.bearing_rad)])
                gaps = np.hypot(*(trees - xy).T)
                if isinstance(obs, SurfacePoint):
                    chain += 1
                    if obs.range_m < 16.0:
                        chain_sigma = max(chain_sigma, math.sqrt(obs.meas_cov[0][0]))
                    continue
                i = int(np.argmin(gaps))
                posts.append((obs.range_m, float(gaps[i]),
                              obs.range_m - float(np.hypot(*trees[i]))))
                post_xy.append(xy)
            post_xy = np.array(post_xy).reshape(-1, 2)
            dist = np.hypot(trees[:, 0], trees[:, 1])
            bearing = np.arctan2(trees[:, 1], trees[:, 0])
            in_view = (dist > 1.0) & (dist < IN_VIEW_M) & (np.abs(bearing) < 0.5 * intr.hfov_rad - 0.05)
            for t in np.flatnonzero(in_view):
                seen += 1
                if len(post_xy) and np.min(np.hypot(*(post_xy - trees[t]).T)) <= FOUND_M:
                    found += 1
    table = np.array(posts).reshape(-1, 3)
    med, p90, bias, n = [], [], [], []
    for lo, hi in RANGE_BANDS_M:
        band = table[(table[:, 0] >= lo) & (table[:, 0] < hi)]
        n.append(len(band))
        med.append(float(np.median(band[:, 1])) if len(band) else math.nan)
        p90.append(float(np.percentile(band[:, 1], 90)) if len(band) else math.nan)
        bias.append(float(np.mean(band[:, 2])) if len(band) else math.nan)
    total = worlds * frames
    return FrameQuality(total, count / total, chain / max(count, 1), tuple(med), tuple(p90),
                        tuple(bias), tuple(n), found / max(seen, 1), chain_sigma)
