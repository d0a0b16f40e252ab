"""``companion campaign``: many seeded simulate runs (or tlog replays) on a Dask cluster.

Nothing here imports Dask at module level: the parser must build, and ``simulate`` must work,
without the cluster extra. Without it this command exits 2 with the install hint.
"""
from __future__ import annotations

import argparse
import csv
import sys
import time

from companion.cli.replay import DEFAULT_CONFIG as REPLAY_CONFIG
from companion.cli.simulate import DEFAULT_SCENARIO, _positive_int
from companion.config.scenario import load_scenario
from companion.core.navigation.decider import STRATEGIES
from companion.errors import CompanionError
from companion.tools.report import _fmt, print_summary, write_json
from companion.sim.worlds import WORLD_KINDS


def add_parser(sub) -> None:
    p = sub.add_parser(
        "campaign", help="many seeded simulate runs, or many tlog replays, on a Dask cluster",
        description="Monte Carlo on Dask: run i flies seed S+i (and world S+i), as `simulate` does, "
                    "so results do not depend on where or how widely they ran. Default: a local "
                    "cluster of one process per core, started and stopped here. "
                    "Needs the cluster extra: pip install .[cluster]")
    what = p.add_mutually_exclusive_group()
    what.add_argument("--random-worlds", choices=sorted(WORLD_KINDS), metavar="KIND",
                      help=f"fly seeded random worlds: run i flies world S+i ({', '.join(sorted(WORLD_KINDS))})")
    p.add_argument("--scenario", help="scenario YAML; with --random-worlds the base whose vehicle, "
                                      f"sensor and guidance are kept (default {DEFAULT_SCENARIO})")
    what.add_argument("--replay", metavar="GLOB", action="append",
                      help="replay tlogs instead: a folder, a file or a quoted glob (repeatable); "
                           "one row per flight in --csv/--json")
    p.add_argument("--runs", type=_positive_int, default=None, help="number of runs (required "
                                                                     "unless --replay)")
    p.add_argument("--seed", type=int, default=0, help="seed of the first run (default 0)")
    p.add_argument("--strategy", choices=STRATEGIES, default=None,
                   help="guidance strategy (default: the scenario's)")
    p.add_argument("--sweep", metavar="NAME=V1,V2,...",
                   help="one row per value of an avoidance parameter (eta, horizon_s, "
                        "safety_distance_m, inflation_sigmas, strategy, ...), same seeds per row")
    p.add_argument("--workers", type=_positive_int, default=None,
                   help="local worker processes (default: one per core)")
    p.add_argument("--scheduler", metavar="ADDRESS",
                   help="use an existing Dask cluster, e.g. tcp://host:8786 (its workers need "
                        "companion installed)")
    p.add_argument("--json", metavar="PATH", help="write the report as JSON")
    p.add_argument("--csv", metavar="PATH", help="with --replay: the per-flight table as CSV")
    p.add_argument("--config", help="with --replay: companion settings for tlogs that have no "
                                    f"FILE.config.yaml beside them (default {REPLAY_CONFIG})")
    p.add_argument("--plot", metavar="PATH", help="histograms of clearance and final position "
                                                  "error (PNG)")
    p.set_defaults(handler=run)


def run(args: argparse.Namespace) -> int:
    from companion.tools import campaign
    campaign.require_dask()             # before any work: exit 2 with the install hint
    if args.scheduler and args.workers:
        raise CompanionError("campaign: --workers sizes the local cluster; it cannot be used with "
                             "--scheduler")
    if args.replay:
        return run_replay(args, campaign)
    if args.csv or args.config:
        raise CompanionError("campaign: --csv and --config are for --replay")
    if args.runs is None:
        raise CompanionError("campaign: give --runs N")
    if args.scenario is None and args.random_worlds is None:
        raise CompanionError("campaign: give --scenario PATH, --random-worlds KIND or --replay GLOB")
    base = load_scenario(args.scenario or DEFAULT_SCENARIO)
    sweep_name, values = campaign.parse_sweep(args.sweep) if args.sweep else (None, [None])
    if sweep_name == "strategy" and args.strategy:
        raise CompanionError("campaign: --strategy and --sweep strategy=... are exclusive")
    if sweep_name == "mission_time_s" and args.random_worlds:
        raise CompanionError("campaign: random worlds set their own mission time; "
                             "sweep mission_time_s with --scenario")
    batches = [campaign.make_batch(base, args.random_worlds, args.strategy,
                                   (sweep_name, v) if sweep_name else None) for v in values]
    started = time.perf_counter()
    with campaign.open_client(args.workers, args.scheduler) as client:
        workers = campaign.worker_threads(client)
        with _progress(args.runs * len(batches)) as bar:
            rows = campaign.run_rows(client, batches, args.seed, args.runs, bar.update, values)
    wall_s = time.perf_counter() - started
    info = {"cluster": args.scheduler or "local", "workers": workers, "runs": args.runs,
            "first_seed": args.seed, "wall_s": round(wall_s, 3)}
    if sweep_name is None:
        report = {"aggregate": rows[0].aggregate(), "runs": rows[0].summaries, "campaign": info}
    else:
        report = {"sweep": {"name": sweep_name, "rows": [
            {"value": row.value, "aggregate": row.aggregate(), "runs": row.summaries}
            for row in rows]}, "campaign": info}
    if args.json:
        write_json(args.json, report)
    if args.plot:
        plot_histograms(args.plot, rows, sweep_name)
    if sweep_name is None:
        print_summary(report, sys.stdout)
    else:
        print_sweep(report["sweep"], sys.stdout)
    print(f"campaign: {args.runs * len(rows)} runs on {workers} workers "
          f"({info['cluster']}) in {wall_s:.1f} s")
    return 0


def run_replay(args: argparse.Namespace, campaign) -> int:
    """``--replay``: every tlog through ``companion replay``'s engine, one row per flight."""
    from companion.config.paths import resolve_config
    for flag in ("runs", "scenario", "sweep", "strategy", "plot"):
        if getattr(args, flag) is not None:
            raise CompanionError(f"campaign: --{flag} does not apply to --replay")
    tlogs = campaign.find_tlogs(args.replay)
    if not tlogs:
        raise CompanionError(f"campaign: no tlog found in {' '.join(args.replay)}")
    default_config = resolve_config(args.config or REPLAY_CONFIG)
    if not default_config.is_file():
        raise CompanionError(f"campaign: {default_config}: no such config file")
    started = time.perf_counter()
    with campaign.open_client(args.workers, args.scheduler) as client:
        workers = campaign.worker_threads(client)
        with _progress(len(tlogs), unit="tlog") as bar:
            rows = campaign.replay_fleet(client, tlogs, default_config, bar.update)
    wall_s = time.perf_counter() - started
    totals = campaign.fleet_totals(rows)
    info = {"cluster": args.scheduler or "local", "workers": workers, "wall_s": round(wall_s, 3),
            "default_config": str(default_config)}
    if args.json:
        write_json(args.json, {"fleet": totals, "flights": rows, "campaign": info})
    if args.csv:
        write_flights_csv(args.csv, rows)
    print_fleet(totals, rows, sys.stdout)
    print(f"campaign: {len(rows)} tlogs on {workers} workers ({info['cluster']}) in {wall_s:.1f} s")
    return 0


def write_flights_csv(path: str, rows: list[dict]) -> None:
    from companion.tools.campaign import FLIGHT_COLUMNS
    with open(path, "w", newline="") as out:
        writer = csv.DictWriter(out, fieldnames=FLIGHT_COLUMNS)
        writer.writeheader()
        for row in rows:
            writer.writerow({k: "" if row[k] is None else row[k] for k in FLIGHT_COLUMNS})


def print_fleet(totals: dict, rows: list[dict], out) -> None:
    out.write(f"flights: {totals['flights']}   failed: {totals['failed']}   damaged: "
              f"{totals['damaged']}   log: {totals['log_hours']:.2f} h   urgent events: "
              f"{totals['urgent_events']}\n"
              f"closest estimated approach: {_fmt(totals['closest_estimated_approach_m'], ' m')}   "
              f"largest position sigma: {_fmt(totals['max_position_sigma_m'], ' m')}\n")
    for row in rows:
        if row["error"] is not None:
            out.write(f"  {row['file']}: {row['error']}\n")


def _progress(total: int, unit: str = "run"):
    """A tqdm bar on a terminal; elsewhere the same object, disabled."""
    from tqdm import tqdm
    return tqdm(total=total, desc="campaign", unit=unit,
                disable=total < 2 or not sys.stderr.isatty())


SWEEP_COLUMNS = (("runs", 5), ("success", 8), ("collide", 8), ("clear min", 10), ("clear p5", 9),
                 ("err med", 8), ("err p95", 8), ("NEES", 6), ("in band", 8))


def sweep_cells(agg: dict) -> list[str]:
    clear, err, nees = agg["min_clearance_m"], agg["final_position_error_m"], agg["nees"]
    band = nees.get("in_band_fraction")
    return [str(agg["runs"]), _fmt(agg["success_rate"]), _fmt(agg["collision_rate"]),
            _fmt(clear["min"], " m"), _fmt(clear["p5"], " m"), _fmt(err["median"], " m"),
            _fmt(err["p95"], " m"), _fmt(nees["mean"]), "n/a" if band is None else f"{100 * band:.0f}%"]


def print_sweep(sweep: dict, out) -> None:
    """One line per sweep value: success, collisions, clearance, error, NEES."""
    name = sweep["name"]
    width = max(len(name), *(len(str(r["value"])) for r in sweep["rows"]))
    out.write(f"{name:>{width}}  " + "  ".join(f"{h:>{w}}" for h, w in SWEEP_COLUMNS) + "\n")
    for row in sweep["rows"]:
        cells = sweep_cells(row["aggregate"])
        out.write(f"{str(row['value']):>{width}}  "
                  + "  ".join(f"{c:>{w}}" for c, (_, w) in zip(cells, SWEEP_COLUMNS)) + "\n")


def plot_histograms(path: str, rows: list, sweep_name: str | None) -> None:
    """Closest approach to an obstacle centre and final position error, one histogram each (PNG).

    With a sweep, one outline per value on shared bins, so the rows compare directly.
    """
    import numpy as np

    from companion.sim.plot import pyplot
    plt = pyplot()

    fig, axes = plt.subplots(1, 2, figsize=(11, 4.2), dpi=110)
    for ax, key, label in ((axes[0], "min_clearance_m", "closest approach to an obstacle centre (m)"),
                           (axes[1], "final_position_error_m", "final position error (m)")):
        data = [np.array([s[key] for s in row.summaries if s[key] is not None], dtype=float)
                for row in rows]
        pooled = np.concatenate(data) if data else np.array([])
        bins = np.histogram_bin_edges(pooled, bins=30) if pooled.size else 10
        for row, values in zip(rows, data):
            name = None if sweep_name is None else f"{sweep_name}={row.value}"
            ax.hist(values, bins=bins, histtype="step" if sweep_name else "bar", lw=1.5,
                    alpha=1.0 if sweep_name else 0.75, label=name)
        if key == "min_clearance_m":
            for d in sorted({row.batch.scenario.safety_distance_m for row in rows}):
                ax.axvline(d, color="red", ls=":", lw=1.2, label=f"safety distance d = {d:g} m")
        ax.set_xlabel(label)
        ax.set_ylabel("runs")
        ax.grid(True, alpha=0.3)
        if ax.get_legend_handles_labels()[0]:
            ax.legend(fontsize=8)
    runs = sum(len(row.results) for row in rows)
    fig.suptitle(f"{rows[0].batch.label}: {runs} runs" + (f", sweep over {sweep_name}" if sweep_name else ""))
    fig.tight_layout()
    fig.savefig(path)
    plt.close(fig)
