"""The aggregate block of ``companion simulate``'s JSON report, from what each run leaves behind
(its summary and its per-step pose NEES): success, clearance, NEES band and the figures of the
runs' kinds (vertical, surface, landmarks, arrival). Shared by simulate, campaigns and the demo."""
from __future__ import annotations

import math

import numpy as np
from scipy.special import gammaincinv


def nees_band(runs: int, dim: int = 3, confidence: float = 0.95) -> tuple[float, float]:
    """Two-sided band for the NEES averaged over ``runs`` runs (chi-square with runs*dim dof)."""
    tail = (1.0 - confidence) / 2.0
    # chi2.ppf(p, k) = 2 gammaincinv(k / 2, p), as scipy.stats computes it (bit for bit:
    # tests/test_simulate_nees.py), without importing scipy.stats (0.5 s of start-up)
    lo, hi = 2.0 * gammaincinv(0.5 * runs * dim, np.array([tail, 1.0 - tail]))
    return float(lo / runs), float(hi / runs)


def aggregate_summaries(summaries: list[dict], pose_nees: list, safety_distance_m: float) -> dict:
    """``aggregate`` from what a run leaves behind: its summary and its per-step pose NEES.

    ``pose_nees[i]`` is run i's NEES sequence (any length); campaigns ship only these, not traces.
    """
    clearances = np.array([s["min_clearance_m"] if s["min_clearance_m"] is not None else math.inf
                           for s in summaries])
    errors = np.array([s["final_position_error_m"] for s in summaries])
    success = [s["reached_goal"] and c >= 0.95 * safety_distance_m
               for s, c in zip(summaries, clearances)]
    steps = min(len(n) for n in pose_nees)
    nees = np.array([np.asarray(n, dtype=float)[:steps] for n in pose_nees]).reshape(len(summaries), steps)
    avg = nees.mean(axis=0) if steps else np.array([])
    lo, hi = nees_band(len(summaries))
    finite_clear = clearances[np.isfinite(clearances)]
    return {
        "runs": len(summaries),
        "success_rate": float(np.mean(success)),
        "collision_rate": float(np.mean([s["collided"] for s in summaries])),
        "min_clearance_m": {
            "min": float(finite_clear.min()) if finite_clear.size else None,
            "p5": float(np.percentile(finite_clear, 5)) if finite_clear.size else None,
            "median": float(np.median(finite_clear)) if finite_clear.size else None,
        },
        "min_surface_clearance_m": surface_figures(summaries),
        "final_position_error_m": {
            "median": float(np.median(errors)), "p95": float(np.percentile(errors, 95)),
            "max": float(errors.max()),
        },
        "nees": {
            "mean": float(avg.mean()) if avg.size else None,
            "in_band_fraction": float(np.mean((avg > lo) & (avg < hi))) if avg.size else None,
            "band": [lo, hi],
            "steps": int(steps),
        },
        "path_length_m": {"median": float(np.median([s["path_length_m"] for s in summaries]))},
        "arrivals": arrival_figures(summaries),
        "landmarks": landmark_figures(summaries),
        **vertical_figures(summaries),
    }


def vertical_figures(summaries: list[dict]) -> dict:
    """The 3D runs' figures ({} when no run is 3D): the mean and median 3D path, the climb, the
    highest altitude, the floor's and bad points refused."""
    rows = [s["vertical"] for s in summaries if "vertical" in s]
    if not rows:
        return {}
    paths = [r["path_3d_m"] for r in rows]
    return {"vertical": {
        "path_3d_m": {"mean": float(np.mean(paths)), "median": float(np.median(paths))},
        "climb_m": {"mean": float(np.mean([r["climb_m"] for r in rows])),
                    "max": float(max(r["climb_m"] for r in rows))},
        "max_altitude_m": float(max(r["max_altitude_m"] for r in rows)),
        "points": {key: sum(r["points"][key] for r in rows) for key in ("ground", "bad_z")},
    }}


def surface_figures(summaries: list[dict]) -> dict:
    """Closest approach to any surface (a circle's centre distance less its radius; walls and
    buildings as in min_clearance_m) over the runs that report it."""
    gaps = np.array([s["min_surface_clearance_m"] for s in summaries
                     if s.get("min_surface_clearance_m") is not None])
    if not gaps.size:
        return {}
    return {"min": float(gaps.min()), "p5": float(np.percentile(gaps, 5)),
            "median": float(np.median(gaps))}


def landmark_figures(summaries: list[dict]) -> dict:
    """Landmarks left in the map at the end against the obstacles the camera had in view, and
    the lifecycle's counters, summed over the runs."""
    rows = [s["landmarks"] for s in summaries if "landmarks" in s]
    if not rows:
        return {}
    ratios = [r["final"] / r["obstacles_seen"] for r in rows if r["obstacles_seen"]]
    total = {key: sum(r[key] for r in rows)
             for key in ("final", "final_confirmed", "obstacles_seen", "confirmed", "deleted",
                         "expired")}
    return {**total,
            "final_per_obstacle_seen": (total["final"] / total["obstacles_seen"]
                                        if total["obstacles_seen"] else None),
            "max_run_ratio": max(ratios, default=None)}


def arrival_figures(summaries: list[dict]) -> dict:
    """How many runs declared arrival, how many held with an uncertain one, and how far from
    the goal the truth was at the worst declared arrival."""
    declared = [s for s in summaries if s.get("arrived")]
    return {
        "declared": len(declared),
        "uncertain": sum(1 for s in summaries if s.get("arrival_uncertain_t_s") is not None),
        "max_true_goal_distance_m": max((s["final_goal_distance_m"] for s in declared),
                                        default=None),
    }
