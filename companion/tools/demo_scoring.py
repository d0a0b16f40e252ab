"""A finished demo flight read and scored: the companion's report and the stub's truth log, aligned
on the vehicle's time since boot, measured as ``companion simulate`` measures a run.

Used by ``companion demo`` (companion/tools/demo.py, which runs the processes) and the ArduPilot
demo (companion/tools/autopilot_demo.py). Reads files, opens no socket, starts no process.
"""
from __future__ import annotations

import asyncio
import json
import logging
import math
from pathlib import Path

import numpy as np

from companion.config.scenario import Scenario
from companion.core import shapes
from companion.core.geometry import wrap_angle
from companion.sim.aggregate import aggregate_summaries
from companion.sim.simulation import ARRIVAL_ALLOWANCE_M
from companion.tools import clearance3d


def read_report(path: Path) -> dict | None:
    try:
        return json.loads(path.read_text())
    except (OSError, ValueError):
        return None


def flight_timing(samples: list, t0_s: float, t_arrival_s: float | None) -> dict:
    """Wall seconds of the flight, from the first vehicle time after ``t0_s`` to the arrival
    (process start-up and the lock-step hold for the companion not counted), and the real-time
    factor; None where the samples cannot tell."""
    none = {"flight_sim_s": None, "flight_wall_s": None, "real_time_factor": None}
    moving = [(w, t) for w, t in samples if t > t0_s + 1e-9]
    if t_arrival_s is None or not moving:
        return none
    wall0, vehicle0 = moving[0]
    end = next((w for w, t in moving if t >= t_arrival_s - 1e-9), None)
    if end is None or end <= wall0:
        return none
    return {"flight_sim_s": round(t_arrival_s - vehicle0, 6), "flight_wall_s": round(end - wall0, 4),
            "real_time_factor": round((t_arrival_s - vehicle0) / (end - wall0), 1)}


def read_truth(path: Path, tail_only: bool = False) -> list[dict]:
    try:
        lines = path.read_text().splitlines()
    except OSError:
        return []
    if tail_only:
        lines = lines[-2:]
    records = []
    for line in lines:
        try:
            records.append(json.loads(line))
        except ValueError:
            continue              # the line being written
    return records


# ------------------------------------------------------------------ scoring
async def wait_until_settled(truth_path: Path, timeout_s: float = 3.0,
                             poll_s: float = 0.1) -> None:
    """Give the vehicle a moment to stop (the truth log's speed), at most ``timeout_s``."""
    try:
        async with asyncio.timeout(timeout_s):
            while True:
                records = read_truth(truth_path, tail_only=True)
                if records and records[-1]["speed_mps"] < 0.05:
                    return
                await asyncio.sleep(poll_s)
    except TimeoutError:
        logging.getLogger(__name__).info("vehicle still moving %.0f s after arrival; scoring "
                                         "anyway", timeout_s)


def score(report: dict, truth: list[dict], scenario: Scenario, seed: int) -> tuple[dict, dict]:
    """The per-run summary of ``companion simulate`` and the arrays to plot."""
    t_true = np.array([r["t_s"] for r in truth])
    true_pose = np.array([[r["north_m"], r["east_m"], r["yaw_rad"]] for r in truth])
    armed = [r["t_s"] for r in truth if r["armed"]]
    t0 = armed[0] if armed else t_true[0]
    t_arrival = report.get("arrival_t_s") or float(t_true[-1])
    track = report["track"]
    t_est = np.array(track["t_s"])
    est_pose = np.column_stack([track["north_m"], track["east_m"], track["yaw_rad"]])
    est_cov = np.array(track["pose_cov"]).reshape(-1, 3, 3)
    flying = (t_est >= t0) & (t_est <= t_arrival + 1e-6)
    t_est, est_pose, est_cov = t_est[flying], est_pose[flying], est_cov[flying]
    true_at_est = np.column_stack([np.interp(t_est, t_true, true_pose[:, k]) for k in range(2)])
    yaw_at_est = np.interp(t_est, t_true, np.unwrap(true_pose[:, 2]))
    errors = np.hypot(*(est_pose[:, :2] - true_at_est).T)
    nees = []
    for est, true_ne, true_yaw, cov in zip(est_pose, true_at_est, yaw_at_est, est_cov):
        err = np.array([true_ne[0] - est[0], true_ne[1] - est[1], wrap_angle(true_yaw - est[2])])
        nees.append(float(err @ np.linalg.solve(cov, err)))

    after_arm = [r for r in truth if r["t_s"] >= t0]
    clearance, surface, collided = math.inf, math.inf, False
    extents = clearance3d.extents_by_id(scenario)          # 3D: over a top, under a base
    for r in after_arm:
        altitude = clearance3d.row_altitude_m(r) if extents else None
        for ob in r["obstacles"]:
            gap = math.hypot(r["north_m"] - ob["north_m"], r["east_m"] - ob["east_m"])
            gap, ob_surface = clearance3d.gaps_m(gap, ob["radius_m"], altitude,
                                                 extents.get(ob["id"], (0.0, math.inf)))
            clearance = min(clearance, gap)
            surface = min(surface, ob_surface)
            collided = collided or ob_surface < 0.0
    # walls and buildings are static: their surfaces against the whole true path at once
    flown = np.array([[r["north_m"], r["east_m"]] for r in after_arm]).reshape(-1, 2)
    outlines = [shape.corners_ne() for _, shape in scenario.world.shapes()]
    for corners in outlines:
        if len(flown):
            gap = float(shapes.polygon_distance_m(flown, corners).min())
            clearance, surface = min(clearance, gap), min(surface, gap)
            collided = collided or gap < 0.0
    flight = np.array([[r["north_m"], r["east_m"]] for r in after_arm if r["t_s"] <= t_arrival])
    path_m = float(np.sum(np.hypot(*np.diff(flight, axis=0).T))) if len(flight) > 1 else 0.0
    goal = scenario.world.goal
    at_arrival = np.array([np.interp(t_arrival, t_true, true_pose[:, k]) for k in range(2)])
    final_goal_distance = float(math.hypot(at_arrival[0] - goal.north_m, at_arrival[1] - goal.east_m))
    # at arrival: later records depend on when the children were stopped
    obstacles_end = next((r["obstacles"] for r in truth if r["t_s"] >= t_arrival),
                         truth[-1]["obstacles"] if truth else [])
    summary = {
        "seed": seed,
        "reached_goal": bool(report.get("arrived"))
        and final_goal_distance <= goal.radius_m + ARRIVAL_ALLOWANCE_M,
        "time_s": round(t_arrival - t0, 6),
        "min_clearance_m": clearance if math.isfinite(clearance) else None,
        "min_surface_clearance_m": surface if math.isfinite(surface) else None,
        "collided": collided,
        "final_goal_distance_m": final_goal_distance,
        "final_position_error_m": float(errors[-1]) if len(errors) else None,
        "max_position_error_m": float(errors.max()) if len(errors) else None,
        "landmark_errors_m": landmark_errors(report["landmarks"], obstacles_end),
        "urgent_events": sum(1 for e in report["urgency_events"]
                             if e["state"] == "urgent" and t0 <= e["t_s"] <= t_arrival),
        "path_length_m": path_m,
    }
    landmarks = report["landmarks"]
    plot = {
        "true_ne": true_pose[t_true >= t0][:, :2], "est_ne": est_pose[:, :2],
        "obstacles_ne": np.array([[o["north_m"], o["east_m"]] for o in obstacles_end]).reshape(-1, 2),
        "obstacle_radii": np.array([o["radius_m"] for o in obstacles_end]),
        "landmarks_ne": np.array([[m["north_m"], m["east_m"]] for m in landmarks]).reshape(-1, 2),
        "landmark_covs": np.array([m["cov_m2"] for m in landmarks]).reshape(-1, 2, 2),
        "shapes_ne": outlines,
        "nees": nees,
    }
    return summary, plot


def landmark_errors(landmarks: list[dict], obstacles: list[dict]) -> list[float]:
    """Error of each mapped obstacle: by id when ids are known, else the nearest landmark < 5 m."""
    by_id = {m["id"]: m for m in landmarks if m["id"] is not None}
    anonymous = np.array([[m["north_m"], m["east_m"]] for m in landmarks if m["id"] is None])
    errors = []
    for ob in obstacles:
        centre = np.array([ob["north_m"], ob["east_m"]])
        if ob["id"] in by_id:
            m = by_id[ob["id"]]
            errors.append(float(np.hypot(m["north_m"] - centre[0], m["east_m"] - centre[1])))
        elif len(anonymous):
            gap = float(np.hypot(*(anonymous - centre).T).min())
            if gap < 5.0:
                errors.append(gap)
    return errors


def demo_result(summary: dict, nees: list[float], scenario: Scenario) -> dict:
    agg = aggregate_summaries([summary], [nees], scenario.safety_distance_m)
    agg["strategy"] = scenario.avoidance.strategy
    agg["scenario"] = scenario.name
    return {"aggregate": agg, "runs": [summary]}
