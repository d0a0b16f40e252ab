"""The service's depth slot (companion/daemon/depth_feed.py): live, the newest frames of each
camera win and what they push out is counted; lock-step, every frame is kept in order."""
import numpy as np

from companion.core.perception.depth_frame import DepthFrame, DepthIntrinsics
from companion.daemon.depth_feed import LIVE_PER_CAMERA, LOCKSTEP_QUEUE, FrameSlot
from companion.depth.frames import SourcedFrame

INTR = DepthIntrinsics.from_fov(8, 6, 87.0, 58.0, 0.3, 20.0, 0.001)


def sourced(number: int, camera: int = 0) -> SourcedFrame:
    return SourcedFrame(DepthFrame(number, 67 * number, camera, INTR,
                                   np.zeros((6, 8), np.uint16)))


def test_live_keeps_the_newest_frames_of_each_camera_and_counts_the_rest():
    slot = FrameSlot(keep_all=False)
    for number in range(5):
        slot.put(sourced(number, 0), 0.0)
        slot.put(sourced(number, 1), 0.0)
    taken = [(s.frame.frame_number, s.frame.camera_id) for s, _ in slot.take()]
    newest = range(5 - LIVE_PER_CAMERA, 5)
    assert sorted(taken) == sorted((n, c) for n in newest for c in (0, 1))
    assert slot.dropped == 2 * (5 - LIVE_PER_CAMERA) and slot.received == 10
    assert slot.last_key == (4, 1) and not slot.frames


def test_lockstep_keeps_every_frame_in_order_up_to_its_bound():
    slot = FrameSlot(keep_all=True)
    for number in range(LOCKSTEP_QUEUE + 3):
        slot.put(sourced(number), 0.0)
    numbers = [s.frame.frame_number for s, _ in slot.take()]
    assert numbers == list(range(3, LOCKSTEP_QUEUE + 3)) and slot.dropped == 3


def test_the_end_of_the_source_is_kept_with_its_error():
    slot = FrameSlot(keep_all=False)
    error = OSError("gone")
    slot.end(error)
    assert slot.ended and slot.error is error and slot.changed.is_set()
