"""Issue 16 (seed 239 of traffic with the flank scan): a crossing mover seen for a few frames
(too briefly for the motion test's min_span_s), out of view, then seen again once its probation
is over. Its sightings show its motion, so it is convicted by them and its track starts from
their fit: velocity, its covariance, and the last point's correlation with it. It used to be
established static on that sighting (the probation's end was judged before the motion test), then
demoted by its next refused sighting and started at rest with initial_speed_sigma_mps: out of view
after that, its track coasted standing still while the mover went on at 4.3 m/s."""
import math

import numpy as np

from companion.config.scenario import load_scenario
from companion.core.estimation.slam_types import Observation
from companion.core.geometry import observe
from companion.core.estimation.movers import MoverTracker, start_evidence
from companion.sim.simulation import make_navigator

DT = 0.2
SPEED = 5.0
MOVER_START = np.array([40.0, -20.0])       # from the vehicle's start
MOVER_VELOCITY = np.array([-0.7, 4.3])
SEEN = (1.0, 1.2, 1.4, 1.6, 4.4, 4.6)      # 0.6 s, out of view, then again after the 3 s probation
COAST_S = 5.0


def coast():
    """The vehicle flies north at 5 m/s (noise-free odometry); the mover is reported at SEEN only.
    Returns its track's state COAST_S after the last sighting and the mover's true position."""
    nav = make_navigator(load_scenario("config/scenarios/paper.yaml"))
    pose = nav.slam.pose.copy()
    start = pose[:2].copy()
    assert abs(pose[2]) < 1e-9                   # the scenario's start faces north
    for step in range(1, round((SEEN[-1] + COAST_S) / DT) + 1):
        t = step * DT
        nav.predict(SPEED, 0.0, DT)
        pose = pose + [SPEED * DT, 0.0, 0.0]
        if any(abs(t - seen) < 1e-6 for seen in SEEN):
            z = observe(pose, start + MOVER_START + MOVER_VELOCITY * t)
            nav.observe([Observation(float(z[0]), float(z[1]), 7)])
    assert len(nav.movers) == 1
    return nav.movers.states(nav.clock_s)[0], \
        start + MOVER_START + MOVER_VELOCITY * (SEEN[-1] + COAST_S)


def test_a_convicted_mover_out_of_view_is_predicted_where_it_goes():
    state, truth = coast()
    error = float(np.hypot(*(state.position_ne_m - truth)))
    sigma = math.sqrt(float(np.linalg.eigvalsh(state.position_cov)[-1]))
    assert error <= sigma                        # within its (worst-axis) sigma of the truth
    assert error < 2.0                           # ... and that sigma is a useful one
    assert np.hypot(*(state.velocity_ne_mps - MOVER_VELOCITY)) < 0.3


def test_a_track_started_from_a_fit_spreads_as_the_fit_does():
    """The start's position-velocity correlation: coasted, the track's position variance is the
    fit's extrapolation's (the last point leans on the slope), not less."""
    times = np.array([0.0, 0.2, 0.4, 0.6, 3.4])
    point_sigma, vel_sigma = 0.1, 0.1 / math.sqrt(float(np.sum((times - times.mean()) ** 2)))
    cov = np.eye(2) * point_sigma ** 2
    tracker = MoverTracker()
    with_cross = tracker.create(3.4, np.zeros(2), cov, None, (np.zeros(2), vel_sigma),
                                start_evidence(times, point_sigma, vel_sigma, cov))
    without = tracker.create(3.4, np.zeros(2), cov, None, (np.zeros(2), vel_sigma))
    # the fit's own extrapolation to t: var = s^2 (1/n + (t - mean)^2 / sum (t_i - mean)^2)
    t = 8.4
    centred = times - times.mean()
    fit_var = point_sigma ** 2 * (1 / len(times) + (t - times.mean()) ** 2 / float(centred @ centred))
    var_with = tracker.state(with_cross, t).position_cov[0, 0]
    var_without = tracker.state(without, t).position_cov[0, 0]
    assert var_without < var_with
    assert var_with >= 0.9 * fit_var


def test_an_old_landmark_that_starts_moving_starts_its_track_at_the_velocity_its_strikes_show():
    """A post watched past its probation, then moving off at 3 m/s: the refused sightings that
    demote it show its velocity, and its track starts at it, not at rest."""
    nav = make_navigator(load_scenario("config/scenarios/paper.yaml"))
    pose = nav.slam.pose.copy()
    post = pose[:2] + [45.0, 8.0]
    velocity = np.array([0.0, -3.0])
    moving_from = 5.0
    track = None
    for step in range(1, 40):
        t = step * DT
        nav.predict(SPEED, 0.0, DT)
        pose = pose + [SPEED * DT, 0.0, 0.0]
        if abs(t - moving_from) < 1e-6:
            assert 7 in nav.slam.landmark_ids() and 7 not in nav.probation.young     # established
        where = post + velocity * max(t - moving_from, 0.0)
        z = observe(pose, where)
        nav.observe([Observation(float(z[0]), float(z[1]), 7)])
        if len(nav.movers):
            track = nav.movers.states(nav.clock_s)[0]
            break
    assert track is not None and track.updates == 0          # just demoted, by its strikes
    assert np.hypot(*(track.velocity_ne_mps - velocity)) < 0.5
