"""VehicleClock: one stamp is never evidence; a new clock needs consecutive agreeing messages."""
import math

import pytest

from companion.onboard.safety.clock import ClockLimits, EpochCamera, VehicleClock


def running(t_s=100.0, **limits):
    clock = VehicleClock(ClockLimits(**limits))
    for i in range(10):
        assert clock.on_autopilot(t_s - 1.0 + 0.1 * i).accepted
    return clock


@pytest.mark.parametrize("t_s, reason", [(3.0, "behind"), (100.0 + 3600.0, "ahead"),
                                         (math.nan, "not_finite"), (math.inf, "not_finite")])
def test_one_stamp_behind_ahead_or_not_finite_is_refused_and_changes_nothing(t_s, reason):
    clock = running()
    latest = clock.latest_t_s
    verdict = clock.on_autopilot(t_s)
    assert (verdict.accepted, verdict.reason) == (False, reason)
    assert clock.latest_t_s == latest
    clock.on_vehicle_heartbeat()
    assert clock.on_autopilot(latest + 0.1).reason == "ok"       # the old clock goes on
    assert not clock.candidate_pending


def test_reordering_within_the_tolerance_is_accepted_without_moving_the_clock_back():
    clock = running()
    latest = clock.latest_t_s
    assert clock.on_autopilot(latest - 0.5).reason == "ok"
    assert clock.latest_t_s == latest
    assert clock.on_autopilot(latest + 0.8).reason == "ok"      # within the ahead window


def test_a_reboot_needs_the_evidence_count_and_a_heartbeat():
    clock = running(evidence_messages=5)
    for i in range(7):                                   # 7 agreeing stamps, no heartbeat
        assert clock.on_autopilot(0.5 + 0.05 * i).reason == "behind"
    clock.on_vehicle_heartbeat()
    verdict = clock.on_autopilot(0.9)
    assert (verdict.accepted, verdict.reason) == (True, "reboot")
    assert clock.latest_t_s == 0.5                       # the first of the evidence
    assert clock.on_autopilot(0.55).reason == "ok"


def test_an_old_clock_message_in_between_breaks_the_evidence():
    clock = running(evidence_messages=3)
    latest = clock.latest_t_s
    clock.on_autopilot(0.5)
    clock.on_vehicle_heartbeat()
    clock.on_autopilot(0.6)
    assert clock.on_autopilot(latest + 0.1).reason == "ok"       # interrupts
    assert clock.on_autopilot(0.7).reason == "behind"            # starts over: 1 of 3
    assert clock.on_autopilot(0.8).reason == "behind"
    clock.on_vehicle_heartbeat()
    assert clock.on_autopilot(0.9).reason == "reboot"


def test_stamps_that_disagree_among_themselves_are_no_evidence():
    clock = running(evidence_messages=3)
    clock.on_vehicle_heartbeat()
    for t_s in (5.0, 40.0, 5.1, 70.0, 5.2, 12.0):        # fuzz: scattered stamps
        assert not clock.on_autopilot(t_s).accepted
    assert clock.latest_t_s == pytest.approx(99.9)


def test_a_forward_jump_confirmed_by_consecutive_messages_is_adopted_without_heartbeat():
    clock = running(evidence_messages=3)
    assert clock.on_autopilot(110.0).reason == "ahead"
    assert clock.on_autopilot(110.1).reason == "ahead"
    assert clock.on_autopilot(110.2).reason == "jump"
    assert clock.latest_t_s == 110.0


def test_camera_frames_are_judged_but_never_evidence():
    clock = running(evidence_messages=2)
    for _ in range(5):
        assert clock.check_frame(1.0).reason == "behind"
        assert clock.check_frame(200.0).reason == "ahead"
    clock.on_vehicle_heartbeat()
    assert not clock.candidate_pending
    assert clock.check_frame(clock.latest_t_s + 0.5).accepted


def test_epoch_camera_maps_by_the_offset_of_its_first_frame():
    cam = EpochCamera()
    assert not cam.is_epoch(100.0) and cam.is_epoch(1.7e9) and not cam.is_epoch(math.nan)
    assert cam.to_vehicle_time(1.7e9, None) is None          # vehicle clock unknown: refused
    assert cam.to_vehicle_time(1.7e9, 42.0) == pytest.approx(42.0)
    assert cam.to_vehicle_time(1.7e9 + 0.2, 99.0) == pytest.approx(42.2)   # offset kept
    cam.forget()
    assert cam.offset_s is None


def test_messages_refused_on_the_adopted_clock_are_returned_in_order_to_handle_again():
    clock = running(evidence_messages=3)
    clock.on_autopilot(5.0, "stray")                     # a candidate of its own, dropped
    clock.on_autopilot(clock.latest_t_s, "old clock")
    clock.on_autopilot(0.5, "a")
    assert not clock.check_frame(0.55, "frame").accepted  # agrees with the candidate: kept
    assert not clock.check_frame(50.0, "far frame").accepted
    clock.on_vehicle_heartbeat()
    clock.on_autopilot(0.6, "b")
    verdict = clock.on_autopilot(0.7, "c")
    assert verdict.reason == "reboot" and verdict.held == ("a", "frame", "b")
    clock.settle(0.7)
    assert clock.latest_t_s == 0.7
