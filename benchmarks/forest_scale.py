"""The bounded map's scale benchmark (issue 28): a 5 km forest route, per-frame cost and memory
per km flown, first km against last.

    python benchmarks/forest_scale.py [--km 5] [--speed-mps 5] [--archive-behind-m 30]
                                      [--archive-unseen-s 10] [--no-archive] [--seed 0]

The route: config/scenarios/forest.yaml's vehicle, camera and estimator, due north for --km
kilometres through a 400-per-ha Poisson-disc forest (companion/sim/forest_worlds.py's process) with a
lane 2 x (d + 1.5 m) wide kept free along the centre line, so that the flight goes the whole
way and the figures measure the map, not the guidance in a forest (forest flights: README). The
camera sees ~15 trees a frame; every tree passed stays in the filter without the archive.

Measured: the companion's own time per 0.1 s step (odometry, position fix, the camera frame when
there is one, the decision; the truth world's time is not counted), p50 and p99 over the steps
with a camera frame in each km; the process's resident set size (/proc/self/statm) at each km's
end; the landmarks in the filter and in the archive. Check (issue 28): the last km's p99 at most
1.2 x the first km's, the RSS at most 10 MB more after 5 km than after the first.
"""
from __future__ import annotations

import argparse
import dataclasses
import math
import os
import time

import numpy as np

from companion.sim import simulation
from companion.config.scenario import load_scenario
from companion.sim.forest_worlds import lane_forest
from companion.sim.simulation import run_once, with_speed

PAGE_BYTES = os.sysconf("SC_PAGE_SIZE")


def rss_mb() -> float:
    with open("/proc/self/statm") as f:
        return int(f.read().split()[1]) * PAGE_BYTES / 1e6


class Timed:
    """Wraps a navigator: times its calls per step, samples the RSS at each km."""

    def __init__(self, nav) -> None:
        self.nav = nav
        self.step_s = 0.0
        self.framed = False
        self.rows: list[tuple[float, float, bool]] = []   # (north_m, seconds, had a frame)
        self.km_rss: list[tuple[float, float, int, int]] = []
        for name in ("on_velocity", "correct_position", "observe", "decide"):
            setattr(self, name, self._timed(getattr(nav, name), name))

    def _timed(self, method, name):
        def call(*args, **kwargs):
            start = time.perf_counter()
            out = method(*args, **kwargs)
            self.step_s += time.perf_counter() - start
            if name == "observe":
                self.framed = True
            if name == "decide":
                self._close_step()
            return out
        return call

    def _close_step(self) -> None:
        north = float(self.nav.slam.pose[0])
        self.rows.append((north, self.step_s, self.framed))
        self.step_s, self.framed = 0.0, False
        km = int(north // 1000.0)
        if km > len(self.km_rss) - 1 and north > 0.0:
            archive = self.nav.archive
            self.km_rss.append((north, rss_mb(), self.nav.slam.landmark_count,
                                0 if archive is None else len(archive)))

    def __getattr__(self, name):
        return getattr(self.nav, name)


def main() -> None:
    parser = argparse.ArgumentParser()
    parser.add_argument("--km", type=float, default=5.0)
    parser.add_argument("--speed-mps", type=float, default=5.0)
    parser.add_argument("--archive-behind-m", type=float, default=30.0)
    parser.add_argument("--archive-unseen-s", type=float, default=10.0)
    parser.add_argument("--no-archive", action="store_true")
    parser.add_argument("--seed", type=int, default=0)
    args = parser.parse_args()
    base = with_speed(load_scenario("config/scenarios/forest.yaml"), args.speed_mps)
    est = base.estimator_config()
    est = dataclasses.replace(est, archive_behind_m=None if args.no_archive
                              else args.archive_behind_m, archive_unseen_s=args.archive_unseen_s)
    base = dataclasses.replace(base, estimator=est)
    scenario = lane_forest(base, 1000.0 * args.km, args.seed)
    wrapped: list[Timed] = []
    make = simulation.make_navigator

    def timed_navigator(*a, **k):
        wrapped.append(Timed(make(*a, **k)))
        return wrapped[-1]

    simulation.make_navigator = timed_navigator
    start = time.perf_counter()
    outcome = run_once(scenario, args.seed)
    wall = time.perf_counter() - start
    timed = wrapped[0]
    rows = np.array([(n, s) for n, s, framed in timed.rows if framed])
    print(f"{scenario.name}: {len(scenario.world.obstacles)} trees, {args.speed_mps:g} m/s, "
          f"archive {'off' if args.no_archive else f'{args.archive_behind_m:g} m behind, {args.archive_unseen_s:g} s unseen'}; "
          f"reached {outcome.summary['reached_goal']}, {outcome.summary['time_s']:.0f} s flown, "
          f"wall {wall:.0f} s, pose NEES mean {np.mean(outcome.trace.pose_nees):.2f}")
    print("| km | frame p50 ms | frame p99 ms | RSS at km end MB | landmarks in filter | archived |")
    print("|---|---|---|---|---|---|")
    p99 = []
    for km in range(int(math.ceil(args.km))):
        sel = rows[(rows[:, 0] >= 1000.0 * km) & (rows[:, 0] < 1000.0 * (km + 1))][:, 1]
        if not sel.size:
            continue
        mark = timed.km_rss[km + 1] if km + 1 < len(timed.km_rss) else \
            (0.0, rss_mb(), timed.nav.slam.landmark_count,
             0 if timed.nav.archive is None else len(timed.nav.archive))
        p99.append(float(np.percentile(sel, 99)))
        print(f"| {km + 1} | {1e3 * np.median(sel):.2f} | {1e3 * p99[-1]:.2f} | {mark[1]:.1f} | "
              f"{mark[2]} | {mark[3]} |")
    first_rss = timed.km_rss[1][1] if len(timed.km_rss) > 1 else math.nan
    print(f"last km p99 / first km p99: {p99[-1] / p99[0]:.2f} (check <= 1.2); RSS growth after "
          f"the first km: {rss_mb() - first_rss:.1f} MB (check <= 10)")


if __name__ == "__main__":
    main()
