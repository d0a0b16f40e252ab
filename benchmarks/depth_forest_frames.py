"""Per-frame quality of the depth perception on rendered random forests (issue 44): how far each
post lies from the trunk it stands for, per range band, and how many observations are chain
points (companion/sim/depth_forest_quality.py says how the frames are drawn).

    nice python -m benchmarks.depth_forest_frames [--worlds 2] [--frames 20] [--seed 0]
        [--scenario config/scenarios/forest-depth.yaml] [--kind forest]
        [--roll-deg 0] [--pitch-deg 0] [--hfov-deg 87] [--vfov-deg 58] [--width 848]
        [--height 480] [--radius LO HI] [--max-jump M] [--bin-deg DEG] [--far-sigmas S]

``--roll-deg`` / ``--pitch-deg`` tilt the mount, ``--hfov-deg`` ... ``--height`` change the
camera, ``--radius`` draws trunks of other radii (held-out cameras and worlds); ``--max-jump``,
``--bin-deg``, ``--far-sigmas`` try other perception parameters.
"""
from __future__ import annotations

import argparse
import dataclasses
import math

from companion.config.scenario import load_scenario
from companion.sim.depth_forest_quality import RANGE_BANDS_M, frame_quality


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--scenario", default="config/scenarios/forest-depth.yaml")
    ap.add_argument("--kind", default="forest")
    ap.add_argument("--worlds", type=int, default=2)
    ap.add_argument("--frames", type=int, default=20)
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--roll-deg", type=float, default=0.0)
    ap.add_argument("--pitch-deg", type=float, default=0.0)
    ap.add_argument("--hfov-deg", type=float, default=None)
    ap.add_argument("--vfov-deg", type=float, default=None)
    ap.add_argument("--width", type=int, default=None)
    ap.add_argument("--height", type=int, default=None)
    ap.add_argument("--radius", type=float, nargs=2, default=None)
    ap.add_argument("--max-jump", type=float, default=None)
    ap.add_argument("--bin-deg", type=float, default=None)
    ap.add_argument("--far-sigmas", type=float, default=None)
    args = ap.parse_args()
    base = load_scenario(args.scenario)
    depth = base.sensor.depth
    changes = {k: v for k, v in (("width_px", args.width), ("height_px", args.height),
                                 ("hfov_deg", args.hfov_deg), ("vfov_deg", args.vfov_deg))
               if v is not None}
    if changes:
        depth = dataclasses.replace(depth, **changes)
    params = base.perception.depth.params(base.perception.ground_margin_m, depth.baseline_m,
                                          depth.subpixel)
    if args.max_jump is not None:
        params = dataclasses.replace(params, blob=dataclasses.replace(params.blob,
                                                                      max_jump_m=args.max_jump))
    if args.bin_deg is not None:
        params = dataclasses.replace(params, bin_deg=args.bin_deg)
    if args.far_sigmas is not None:
        params = dataclasses.replace(params, far_sigmas=args.far_sigmas)
    mount = dataclasses.replace(base.sensor.camera_mounts()[0],
                                roll_rad=math.radians(args.roll_deg),
                                pitch_rad=math.radians(args.pitch_deg))
    q = frame_quality(base, params, depth, mount, args.worlds, args.frames, args.seed, args.kind,
                      args.radius)
    print(f"frames {q.frames}, observations per frame {q.observations_per_frame:.1f}, chain "
          f"points {q.chain_share:.0%}, trunks in view found {q.found_share:.0%}, largest chain "
          f"range sigma within 16 m "
          f"{q.max_chain_sigma_near_m:.2f} m")
    for (lo, hi), n, med, p90, bias in zip(RANGE_BANDS_M, q.posts, q.post_median_m,
                                           q.post_p90_m, q.post_range_bias_m):
        print(f"  posts at {lo:4.0f}-{hi:2.0f} m: {n:4d}, centre error median {med:.2f} m, "
              f"p90 {p90:.2f} m, range bias {bias:+.2f} m")


if __name__ == "__main__":
    main()
