"""The companion's depth perception (issue 44): time per frame, and what it reports against the
d4xx method on the same rendered frames.

    nice python -m benchmarks.depth_perception [--frames 200] [--decimation 4] [--seed 1]

Frames: companion/sim/depth_render.py's renderer at 848x480 (a D455's depth mode, 87 x 58 deg,
its stereo error, occlusion shadows and 1% dropout), from a camera 10 m up flying north through a
forest of 50 trees (0.1 to 0.4 m radius, unbounded height) within 20 m ahead, a new viewpoint
each frame. Figures printed:

1. ``perceive`` (core/perception/depth_perception.py) per frame, p50 / p99 / max in ms, with the
   points, floor points and observations per frame; and what that costs a core at 15 Hz
   (p50 x 15: the fraction of one core the perception alone takes).
2. The d4xx method, as ALGORITHM-NOTES "Depth cameras" describes ArduPilot's d4xx_to_mavlink.py
   (written here from that description, not from the script): one band of rows (10 rows, at the
   image's centre for a level camera), the minimum depth per column over the band, the minimum
   over the columns of each of 72 bins across the view; a zero (no data) in the band is the
   minimum, so the bin reports nothing. Its time per frame on the same frames.
3. Three cases rendered without noise, each side by side: a low wall under the band (1.5 m high
   at 8 m ahead of a camera at 5 m), an overhang above it (a deck 1 m above the camera, 8 m
   ahead, from 6 m to 9 m up), a post behind a hole pixel (a 0.3 m post at 10 m ahead, one
   pixel of the band's column on it without data).
"""
from __future__ import annotations

import argparse
import math
import time

import numpy as np

from companion.config.depth import DepthConfig
from companion.core.perception.depth_frame import CameraMount, DepthFrame, DepthIntrinsics
from companion.core.perception.depth_perception import DepthPerceptionParams, perceive
from companion.sim.depth_camera import TruePose, camera_pose
from companion.sim.depth_render import (DepthRenderer, DepthScene, Prism, StereoErrors,
                                        sensor_errors)

BAND_ROWS = 10
D4XX_BINS = 72


def d4xx_distances(depth: np.ndarray, intr: DepthIntrinsics, band_centre_row: int,
                   bins: int = D4XX_BINS) -> np.ndarray:
    """(bins,) metres, NaN where the bin reports nothing: the minimum over a band of rows and
    over each bin's columns, a zero pixel (no data) being the minimum (the bin blanks)."""
    top = max(0, band_centre_row - BAND_ROWS // 2)
    band = depth[top:top + BAND_ROWS]
    per_column = band.min(axis=0).astype(float) * intr.depth_scale_m
    edges = np.linspace(0, intr.width_px, bins + 1).astype(int)
    out = np.minimum.reduceat(per_column, edges[:-1])
    return np.where(out > 0.0, out, np.nan)


def forest_scene(rng: np.random.Generator, north_m: float, trees: int = 50) -> DepthScene:
    ahead = rng.uniform(2.0, 20.0, trees)
    across = rng.uniform(-1.0, 1.0, trees) * ahead * math.tan(math.radians(43.5))
    ne = np.column_stack((north_m + ahead, across))
    return DepthScene(ne, rng.uniform(0.1, 0.4, trees), np.zeros(trees), np.full(trees, np.inf))


def render(renderer: DepthRenderer, scene: DepthScene, pose: TruePose, errors: StereoErrors,
           rng: np.random.Generator) -> np.ndarray:
    rotation, origin = camera_pose(pose, CameraMount())
    true_m = renderer.render_m(rotation, origin, scene)
    return sensor_errors(true_m, renderer.intrinsics, errors, rng)


def timing(frames: int, decimation: int, seed: int) -> None:
    intr = DepthConfig().intrinsics()
    renderer = DepthRenderer(intr)
    errors = StereoErrors.of(DepthConfig())
    rng = np.random.default_rng(seed)
    params = DepthPerceptionParams(decimation=decimation)
    mine, d4xx, counts = [], [], []
    for i in range(frames):
        pose = TruePose(0.3 * i, 0.0, 10.0, float(rng.normal(0, 0.03)), float(rng.normal(0, 0.05)))
        pixels = render(renderer, forest_scene(rng, 0.3 * i), pose, errors, rng)
        frame = DepthFrame(i, 0, 0, intr, pixels)
        t0, c0 = time.perf_counter(), time.process_time()
        got = perceive(frame, CameraMount(), pose.roll_rad, pose.pitch_rad, 10.0, params)
        t1, c1 = time.perf_counter(), time.process_time()
        d4xx_distances(pixels, intr, intr.height_px // 2)
        t2, c2 = time.perf_counter(), time.process_time()
        mine.append((t1 - t0, c1 - c0))
        d4xx.append((t2 - t1, c2 - c1))
        counts.append((got.points, got.floor_points, len(got.observations), len(got.posts)))
    c = np.array(counts)
    for name, times in (("perceive", mine), ("d4xx method", d4xx)):
        ms = 1e3 * np.array(times)
        wall, cpu = ms[:, 0], ms[:, 1]
        print(f"{name} at {intr.width_px}x{intr.height_px}"
              + (f", decimation {decimation}" if name == "perceive" else
                 f" (band of {BAND_ROWS} rows, {D4XX_BINS} bins)")
              + f", {frames} forest frames: wall p50 {np.percentile(wall, 50):.2f} ms, p99 "
              f"{np.percentile(wall, 99):.2f} ms, max {wall.max():.2f} ms; CPU p50 "
              f"{np.percentile(cpu, 50):.2f} ms, p99 {np.percentile(cpu, 99):.2f} ms")
        if name == "perceive":
            print(f"  per frame: {c[:, 0].mean():.0f} points, {c[:, 1].mean():.0f} floor, "
                  f"{c[:, 2].mean():.1f} observations, {c[:, 3].mean():.1f} posts; at 15 Hz "
                  f"{15.0 * np.percentile(cpu, 50) / 10.0:.1f}% of one core (CPU p50 x 15)")


def cases() -> None:
    intr = DepthConfig().intrinsics()
    renderer = DepthRenderer(intr)
    params = DepthPerceptionParams()
    pose = TruePose(0.0, 0.0, 5.0)
    none = StereoErrors.none()
    rng = np.random.default_rng(0)
    wall = np.array([[8.0, -6.0], [8.2, -6.0], [8.2, 6.0], [8.0, 6.0]])
    deck = np.array([[8.0, -4.0], [12.0, -4.0], [12.0, 4.0], [8.0, 4.0]])
    empty = np.zeros((0, 2)), np.zeros(0), np.zeros(0), np.zeros(0)
    scenes = {
        "low wall under the band (1.5 m high, 12 m wide, 8 m ahead, camera at 5 m)":
            DepthScene(*empty, (Prism(wall, 0.0, 1.5),)),
        "overhang above the band (deck 6-9 m up, 8 m ahead, camera at 5 m)":
            DepthScene(*empty, (Prism(deck, 6.0, 9.0),)),
        "post behind a hole pixel (0.3 m post, 10 m ahead)":
            DepthScene(np.array([[10.0, 0.0]]), np.array([0.3]), np.zeros(1),
                       np.array([np.inf])),
    }
    for name, scene in scenes.items():
        pixels = render(renderer, scene, pose, none, rng)
        whole = d4xx_distances(pixels, intr, intr.height_px // 2)
        if "hole" in name:
            row, col = intr.height_px // 2, intr.width_px // 2
            pixels = pixels.copy()
            pixels[row, col] = 0
        d4 = d4xx_distances(pixels, intr, intr.height_px // 2)
        blanked = np.flatnonzero(np.isfinite(whole) & ~np.isfinite(d4))
        got = perceive(DepthFrame(0, 0, 0, intr, pixels), CameraMount(), 0.0, 0.0, 5.0, params)
        seen = [f"{o.range_m:.1f} m at {math.degrees(o.bearing_rad):+.0f} deg, "
                f"{5.0 - o.top_down_m:.1f} to {5.0 - o.bottom_down_m:.1f} m up"
                for o in got.observations]
        d4_seen = np.flatnonzero(np.isfinite(d4))
        print(f"{name}:")
        print(f"  d4xx: {len(d4_seen)} of 72 bins hold something"
              + (f", nearest {np.nanmin(d4):.2f} m" if len(d4_seen) else "")
              + (f"; the hole blanked bin(s) {blanked.tolist()} of the "
                 f"{int(np.isfinite(whole).sum())} that saw the post" if len(blanked) else ""))
        print(f"  perceive: {len(got.observations)} observations"
              + (f"; nearest {seen[int(np.argmin([o.range_m for o in got.observations]))]}"
                 if seen else ""))


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--frames", type=int, default=200)
    parser.add_argument("--decimation", type=int, default=4)
    parser.add_argument("--seed", type=int, default=1)
    args = parser.parse_args()
    timing(args.frames, args.decimation, args.seed)
    cases()


if __name__ == "__main__":
    main()
