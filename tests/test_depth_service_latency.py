"""benchmarks/depth_service.py's capture -> setpoint rule: a frame that gave observations is
answered by the first setpoint sent after its observations were absorbed, its capture tied to the
companion's clock by the fastest delivery near it (a loaded stub falls behind and rebases)."""
import numpy as np
import pytest

from benchmarks.depth_service import capture_to_setpoint_s, offset_at

T0 = 1_700_000_000.0


def test_each_frame_is_answered_by_the_next_setpoint_after_its_absorption():
    boot = np.array([0.0, 0.1, 0.2, 5.0, 5.1])
    gap = np.array([T0 + 0.004, T0 + 0.002, T0 + 0.003, T0 + 0.502, T0 + 0.501])  # rebased by 0.5 s
    sent = np.array([T0 + 0.15, T0 + 0.25, T0 + 5.58])
    absorbed = [
        (0.10, T0 + 0.16, 2, T0 + 0.12),      # answered by the setpoint at 0.25
        (0.133, T0 + 0.16, 0, T0 + 0.15),     # no observation: nothing to answer
        (0.05, T0 + 0.14, 1, T0 + 0.09),      # before the first setpoint: not commanding yet
        (5.067, T0 + 5.57, 1, T0 + 5.55),     # after the rebase: tied near its capture
    ]
    total, read = capture_to_setpoint_s(absorbed, sent, boot, gap)
    assert total == pytest.approx([0.25 - 0.10 - 0.002, 5.58 - 5.067 - 0.501], abs=1e-6)
    assert read == pytest.approx([0.12 - 0.10 - 0.002, 5.55 - 5.067 - 0.501], abs=1e-6)


def test_the_tie_is_the_fastest_delivery_within_the_window():
    boot = np.array([0.0, 0.5, 3.0])
    gap = np.array([10.0, 9.9, 12.0])
    assert offset_at(0.2, boot, gap) == 9.9
    assert offset_at(3.1, boot, gap) == 12.0
    assert offset_at(100.0, boot, gap) == 9.9        # nothing near: the flight's fastest
