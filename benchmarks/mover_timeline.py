"""What the vehicle knew of the mover it came nearest, and when (issue 33's diagnosis).

    python benchmarks/mover_timeline.py --scenario config/scenarios/copter.yaml \
        --random-worlds head-on --seed 35 [--every 2]
    python benchmarks/mover_timeline.py --scenario /tmp/heldout-headon/heldout-ids-3.yaml --seed 7003

Flies one seeded run exactly as ``companion simulate`` does (simulation.run_once, same seed),
watching from outside: the navigator's decide and the camera's frames are wrapped, nothing else
changes. Prints, for the obstacle of the closest approach: its first sighting (time, range), the
first decision that flew round it while still on probation (young evidence: velocity and sigma),
its confirmation, its track (the velocity and its sigma), then every ``--every``-th decision from
the first sighting to the closest approach: range, the vehicle's speed, the command (mode,
speed, heading) and what the navigator had of the mover. Ids come from the camera (report_ids).
"""
from __future__ import annotations

import argparse
import math
import sys

import numpy as np

import companion.sim.simulation as simulation
from companion.config.scenario import load_scenario
from companion.sim.worlds import random_world


def timeline(scenario, seed: int) -> dict:
    records: list[dict] = []
    made = {}
    original_make = simulation.make_navigator
    original_run_truth = simulation.TruthWorld

    class WatchedTruth(original_run_truth):
        def observe(self):
            frame = super().observe()
            made["frames"].append((self.t_s, {o.obstacle_id: o.range_m for o in frame}))
            return frame

    def watched_make(*args, **kwargs):
        nav = original_make(*args, **kwargs)
        decide = nav.decide

        def watched_decide(t_s):
            truth = made["truth"]
            command, change = decide(t_s)
            tracks = {m.obstacle_id: m for m in nav.movers.states(nav.clock_s)}
            records.append(dict(
                t=t_s, pose=truth.pose.copy(), vel=None if getattr(truth, "vel_ne_mps", None) is None else truth.vel_ne_mps.copy(),
                obstacles=truth.obstacle_positions().copy(), mode=command.mode,
                speed=command.speed_mps, heading=math.degrees(command.heading_rad),
                young={k: (v[0].copy(), v[1]) for k, v in nav.view.young_found.items()},
                tentative={k for k in nav.slam.landmark_ids() if nav.lifecycle.is_tentative(k)},
                mapped=set(nav.slam.landmark_ids()),
                tracks={k: (m.position_ne_m.copy(), m.velocity_ne_mps.copy(),
                            None if m.velocity_cov is None else
                            math.sqrt(float(np.linalg.eigvalsh(m.velocity_cov)[-1])))
                        for k, m in tracks.items()}))
            return command, change

        nav.decide = watched_decide
        made["nav"] = nav
        return nav

    def truth_factory(*args, **kwargs):
        truth = WatchedTruth(*args, **kwargs)
        made["truth"] = truth
        made["frames"] = []
        return truth

    simulation.make_navigator = watched_make
    simulation.TruthWorld = truth_factory
    try:
        outcome = simulation.run_once(scenario, seed)
    finally:
        simulation.make_navigator = original_make
        simulation.TruthWorld = original_run_truth
    return {"outcome": outcome, "records": records, "frames": made["frames"],
            "ids": [o.id for o in scenario.world.obstacles],
            "vels": [(o.vel_north_mps, o.vel_east_mps) for o in scenario.world.obstacles],
            "radii": [o.radius_m for o in scenario.world.obstacles]}


def report(result: dict, every: int, out=sys.stdout) -> None:
    recs = result["records"]
    ids = result["ids"]
    gaps = np.array([np.hypot(*(r["obstacles"] - r["pose"][:2]).T) for r in recs])  # (T, n)
    step, row = np.unravel_index(np.argmin(gaps), gaps.shape)
    oid = ids[row]
    cpa = recs[step]
    print(f"{result['outcome'].summary['min_clearance_m']:.2f} m min clearance; nearest obstacle "
          f"{oid} (v {result['vels'][row][0]:+.1f}, {result['vels'][row][1]:+.1f} m/s, r "
          f"{result['radii'][row]:.1f} m) at t {cpa['t']:.1f} s, {gaps[step, row]:.2f} m", file=out)
    seen = [(t, f[oid]) for t, f in result["frames"] if oid in f]
    if not seen:
        print("  never seen", file=out)
        t0 = cpa["t"] - 8.0            # the last 8 s before the CPA, for what the vehicle did
    else:
        t0 = seen[0][0]
        print(f"  first sighting t {t0:.1f} s at {seen[0][1]:.1f} m; frames seen before CPA: "
              f"{sum(t <= cpa['t'] for t, _ in seen)}", file=out)

    def first(pred):
        return next((r for r in recs if r["t"] >= t0 and pred(r)), None)
    marks = [("young evidence", first(lambda r: oid in r["young"])),
             ("confirmed", first(lambda r: oid in r["mapped"] and oid not in r["tentative"])),
             ("track", first(lambda r: oid in r["tracks"]))]
    for name, r in marks:
        if r is None:
            print(f"  {name}: never", file=out)
            continue
        rng = float(np.hypot(*(r["obstacles"][row] - r["pose"][:2])))
        extra = ""
        if name == "young evidence":
            v, s = r["young"][oid]
            extra = f" v ({v[0]:+.2f}, {v[1]:+.2f}) sigma {s:.2f}"
        if name == "track":
            p, v, s = r["tracks"][oid]
            extra = (f" v ({v[0]:+.2f}, {v[1]:+.2f}) sigma {s if s is None else round(s, 2)}, "
                     f"position off {np.hypot(*(p - r['obstacles'][row])):.2f} m")
        print(f"  {name}: t {r['t']:.1f} s (+{r['t'] - t0:.1f}), range {rng:.1f} m{extra}", file=out)
    print("   t     range  v_veh   mode          cmd_v  cmd_hdg  nose  bearing  knows", file=out)
    shown = [r for r in recs if t0 - 0.5 <= r["t"] <= cpa["t"] + 1.0]
    for k, r in enumerate(shown):
        if k % every and r is not shown[-1]:
            continue
        rng = float(np.hypot(*(r["obstacles"][row] - r["pose"][:2])))
        knows = ("track" if oid in r["tracks"] else "young" if oid in r["young"]
                 else "tentative" if oid in r["tentative"] else "mapped" if oid in r["mapped"]
                 else "-")
        vel = r["vel"]
        vv = float(np.hypot(*vel)) if vel is not None else float("nan")
        gap = r["obstacles"][row] - r["pose"][:2]
        bearing = math.degrees(math.remainder(math.atan2(gap[1], gap[0]) - r["pose"][2], 2 * math.pi))
        print(f"  {r['t']:5.1f} {rng:6.1f} {vv:5.1f}   {r['mode'][:12]:12s} {r['speed']:5.1f} "
              f"{r['heading']:7.0f} {math.degrees(r['pose'][2]):5.0f}  {bearing:7.0f}  {knows}",
              file=out)


def main() -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--scenario", default="config/scenarios/copter.yaml")
    p.add_argument("--random-worlds", help="fly this kind's world of the seed (default: the "
                   "scenario's own world, e.g. a file benchmarks/heldout_headon.py wrote)")
    p.add_argument("--seed", type=int, required=True)
    p.add_argument("--every", type=int, default=2, help="print every N-th decision")
    p.add_argument("--speed-mps", type=float, help="cruise speed, as companion simulate's")
    args = p.parse_args()
    scenario = simulation.with_speed(load_scenario(args.scenario), args.speed_mps)
    world = random_world(scenario, args.random_worlds, args.seed) if args.random_worlds \
        else scenario
    report(timeline(world, args.seed), args.every)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
