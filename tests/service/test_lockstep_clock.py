"""companion/daemon/lockstep.py: in lock-step the link clock is the vehicle's clock."""
from __future__ import annotations

from companion.mavlink import codec
from companion.config.service import load_config
from companion.daemon.lockstep import VehicleLinkClock, lockstep_config
from companion.config.paths import resolve_config

BASE_S = 1_700_000_000.0


def position(t_s: float) -> codec.LocalPosition:
    return codec.LocalPosition(1, 1, t_s, 0.0, 0.0, 0.0, 0.0)


def test_the_clock_moves_only_with_the_vehicle_time_and_never_back():
    clock = VehicleLinkClock(1.0, base_unix_s=BASE_S)
    assert not clock.started and clock.observe(None) == int(BASE_S * 1e6)
    assert clock.observe(position(2.5)) == int(BASE_S * 1e6) + 2_500_000
    assert clock.observe(position(2.4)) == int(BASE_S * 1e6) + 2_500_000   # late: no step back
    heartbeat = codec.Heartbeat(1, 1, 2, 3, True, 4)
    assert clock.observe(heartbeat) == clock.now_us()                     # no time of its own
    # a reboot (time_boot_ms back to 0.1 s): the clock carries on from 2.5 s
    assert clock.observe(position(0.1)) == int(BASE_S * 1e6) + 2_500_000
    assert clock.observe(position(0.6)) == int(BASE_S * 1e6) + 3_000_000


def test_heartbeats_are_due_once_per_period_of_vehicle_time():
    clock = VehicleLinkClock(1.0, base_unix_s=BASE_S)
    assert not clock.heartbeat_due()             # nothing before the vehicle's clock starts
    due = []
    for step in range(31):
        clock.observe(position(step / 10))
        due.append(clock.heartbeat_due())
    assert [i for i, d in enumerate(due) if d] == [0, 10, 20, 30]


def test_lockstep_config_publishes_one_odometry_per_position():
    config = load_config(resolve_config("config/companion.yaml"))
    assert config.commanding.odometry_rate_hz < config.streams.local_position_rate_hz
    assert lockstep_config(config).commanding.odometry_rate_hz == \
        config.streams.local_position_rate_hz
