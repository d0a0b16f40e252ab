"""Issue 31, GPS outage and return, in-process (`companion simulate`'s loop): a multicopter on a
1 km leg loses its GPS at 30 s for 30, 120 or 600 s, its velocity off meanwhile (no longer
GPS-aided). Within what the filter assumes of an unaided velocity (0.3 m/s against its 0.1 m/s
per axis, 3 sigma), the returning fixes are fused: bridged, no reset. An IMU-only dead reckoning
(1 m/s, 10x) puts them far outside the gate: one reset, 7 s after the return (EKF3's own
timeout), then the goal. Never an arrival declared falsely (reached_goal: the truth within the
goal radius + 2 m when arrival is declared), never a collision."""
from __future__ import annotations

import dataclasses

import pytest

from companion.config.scenario import load_scenario
from companion.sim.simulation import run_once

OUTAGE_START_S = 30.0


def outage_run(duration_s: float, bias_mps: float, seed: int = 0, leg_m: float = 1000.0):
    base = load_scenario("config/scenarios/copter.yaml")
    world = dataclasses.replace(base.world, goal=dataclasses.replace(
        base.world.goal, north_m=base.world.start.north_m + leg_m))
    noise = dataclasses.replace(base.noise, gps_outages_s=((OUTAGE_START_S, duration_s),),
                                outage_velocity_bias_mps=bias_mps)
    mission = dataclasses.replace(base.mission, max_time_s=leg_m / 5.0 * 1.5 + duration_s)
    scenario = dataclasses.replace(base, world=world, noise=noise, mission=mission)
    return run_once(scenario, seed).summary


@pytest.mark.parametrize("duration_s, bias_mps, resets", [
    (30.0, 0.3, 0), pytest.param(120.0, 0.3, 0, marks=pytest.mark.slow), (30.0, 1.0, 1),
    (120.0, 1.0, 1), pytest.param(600.0, 1.0, 1, marks=pytest.mark.slow)])
def test_outage_is_bridged_or_reset_once_and_the_goal_reached(duration_s, bias_mps, resets):
    run = outage_run(duration_s, bias_mps)
    end_s = OUTAGE_START_S + duration_s
    assert run["reached_goal"] and not run["collided"] and run["min_clearance_m"] >= 9.5
    assert len(run["position_resets"]) == resets
    drift_m = bias_mps * duration_s
    assert run["max_position_error_m"] > 0.9 * drift_m      # the outage was there and drifted
    if resets:
        t_s, offset_m = run["position_resets"][0]
        assert end_s + 6.0 <= t_s <= end_s + 8.5           # 7 s of refused fixes after the return
        assert offset_m > 0.9 * drift_m
    assert run["final_position_error_m"] < 2.0


def test_without_the_reset_the_fixes_stay_refused_and_the_vehicle_holds():
    """The old behaviour, for contrast: refused for ever (arrival never declared: the claimed
    uncertainty stays large), never a false arrival either."""
    base = load_scenario("config/scenarios/gps-outage.yaml")
    est = dataclasses.replace(base.estimator_config(), position_reset_after_s=None)
    run = run_once(dataclasses.replace(base, estimator=est), 0).summary
    assert run["position_resets"] == [] and not run["reached_goal"]
    assert run["position_fixes"]["refused"] > 100 and run["final_position_error_m"] > 50.0


def test_the_stub_scenario_resets_once_in_process_too():
    run = run_once(load_scenario("config/scenarios/gps-outage.yaml"), 0).summary
    assert run["reached_goal"] and len(run["position_resets"]) == 1
