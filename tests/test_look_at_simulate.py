"""`companion simulate` with avoidance.look_at_threats (issue 16): a mover crossing from ahead-right
slides out of the multicopter's 90 degree view as it closes in; with the look the nose follows it
(apart from the velocity) and the vehicle passes it with the safety distance kept; without, the
nose stays on the velocity."""
from __future__ import annotations

import math

import numpy as np
import pytest
import yaml

from companion.config.scenario import load_scenario
from companion.sim.simulation import run_once
from tests.e2e.support import REPO

MOVER = {"id": 3, "north_m": 50.0, "east_m": 20.0, "radius_m": 1.0,
         "vel_north_mps": 0.0, "vel_east_mps": -3.0}


def crossing(tmp_path, look: bool):
    data = yaml.safe_load((REPO / "config" / "scenarios" / "copter.yaml").read_text())
    data["world"]["obstacles"] = [MOVER]
    data["avoidance"]["look_at_threats"] = look
    data["avoidance"]["goal_look_deg"] = None     # the look at threats alone (test_goal_look.py)
    path = tmp_path / f"crossing-{look}.yaml"
    path.write_text(yaml.safe_dump(data))
    return load_scenario(path)


def nose_and_mover(outcome):
    """Per step: the nose apart from the velocity's direction (> 30 deg), the true mover within
    the true nose's view, and the mover off the velocity's direction beyond half the view."""
    poses, t = np.array(outcome.trace.true_pose), np.array(outcome.trace.t_s)
    step = np.diff(poses[:, :2], axis=0)
    course, yaw = np.arctan2(step[:, 1], step[:, 0]), poses[1:, 2]
    mover = np.stack([np.full(len(t) - 1, MOVER["north_m"]),
                      MOVER["east_m"] + MOVER["vel_east_mps"] * t[1:]], axis=1)
    bearing = np.arctan2(mover[:, 1] - poses[1:, 1], mover[:, 0] - poses[1:, 0])

    def off(a, b):
        return np.abs(np.remainder(a - b + np.pi, 2 * np.pi) - np.pi)
    return (off(yaw, course) > math.radians(30.0), off(bearing, yaw) < math.radians(45.0),
            off(bearing, course) > math.radians(45.0))


# Seeds where the mover slides out of view as a threat. Since the young points' shared yaw error
# is counted once (motion_evidence.shared_yaw_velocity_cov), two sightings convict the mover on the
# multicopter too, and on seeds 1-3, 6 and 7 the velocity choice already flies round it before it
# leaves the view (passed at 11.2-11.4 m, no look due); on 0, 4 and 5 it still becomes a threat
# from out of view (looks of 111-114 steps, passed at 11.0-11.1 m).
@pytest.mark.parametrize("seed", [0, 4])
def test_the_nose_follows_a_crossing_mover_out_of_view_and_it_is_avoided(tmp_path, seed):
    outcome = run_once(crossing(tmp_path, look=True), seed)
    summary = outcome.summary
    assert summary["reached_goal"] and not summary["collided"]
    assert summary["min_clearance_m"] >= 9.5
    apart, nose_on, unseen_from_course = nose_and_mover(outcome)
    assert apart.sum() >= 20                         # 2 s or more of looking
    assert nose_on[apart].mean() >= 0.5              # at the mover...
    assert unseen_from_course[apart].mean() >= 0.9   # ...that the velocity's view would not see


def test_without_the_look_the_nose_stays_on_the_velocity(tmp_path):
    outcome = run_once(crossing(tmp_path, look=False), 0)
    apart, _, _ = nose_and_mover(outcome)
    assert outcome.summary["reached_goal"] and apart.sum() <= 3     # turning steps only
