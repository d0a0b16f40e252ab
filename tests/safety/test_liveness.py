"""Liveness: camera from its obstacle messages (vehicle time), vehicle from its heartbeat (link)."""
from companion.onboard.safety.liveness import Liveness


def test_camera_stale_after_the_timeout_of_vehicle_time_and_live_on_an_empty_frame():
    live = Liveness(3.0, 3.5, require_camera=True)
    assert live.camera_stale(10.0)                       # none yet, required
    live.on_camera_frame(10.0, 10.0)
    assert not live.camera_stale(13.4) and live.camera_stale(13.6)


def test_a_frame_stamped_in_the_future_counts_only_up_to_the_vehicle_clock():
    live = Liveness(3.0, 3.5, require_camera=True)
    live.on_camera_frame(10.0 + 3600.0, 10.0)
    assert live.last_camera_t_s == 10.0
    assert live.camera_stale(20.0)                       # 10 s of silence after it: stale


def test_heartbeat_freshness_on_the_link_clock():
    live = Liveness(3.0, 3.5, require_camera=False)
    assert not live.heartbeat_fresh(0.0)
    live.on_vehicle_heartbeat(100.0)
    assert live.heartbeat_fresh(103.0) and not live.heartbeat_fresh(103.1)
    assert not live.camera_stale(1e6)                    # no camera required, none seen
