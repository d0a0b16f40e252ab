"""STATUSTEXT limiter and stream-rate watch (pure: time is an argument)."""
from companion.onboard.safety.notices import NoticeLimiter
from companion.onboard.stream_rates import StreamRateWatch


def test_the_same_text_at_most_once_per_repeat_interval():
    lim = NoticeLimiter(repeat_s=5.0, per_s=10)
    assert lim.admit("a", 0.0)
    assert not lim.admit("a", 1.0) and not lim.admit("a", 4.9)
    assert lim.admit("a", 5.0)
    assert lim.suppressed == 2


def test_a_total_cap_per_second_and_the_suppressed_count_is_reported():
    lim = NoticeLimiter(repeat_s=5.0, per_s=2)
    admitted = [lim.admit(f"text {i}", 0.1 * i) for i in range(50)]    # 50 in 5 s
    assert sum(admitted) <= 2 * 5 + 1 and lim.suppressed == 50 - sum(admitted)
    assert lim.take_suppressed_report(0.45) is None         # budget spent this second
    text = lim.take_suppressed_report(20.0)
    assert text == f"companion: {lim.suppressed} notices suppressed"
    assert lim.take_suppressed_report(40.0) is None          # reported once


def feed(watch, t0, seconds, hz_by_id):
    for k in range(int(seconds * 100)):
        t = t0 + k / 100
        for msg_id, hz in hz_by_id.items():
            if k % int(100 / hz) == 0:
                watch.on_message(msg_id)
    return t0 + seconds


def test_a_stream_below_the_fraction_is_asked_again_a_bounded_number_of_times():
    watch = StreamRateWatch({30: 10.0, 32: 10.0}, window_s=5.0, min_fraction=0.5,
                            max_reasserts=2)
    watch.restart(0.0)
    t = feed(watch, 0.0, 5.0, {30: 10, 32: 4})           # a router set 32 to 4 Hz
    assert watch.check(t) == [32]
    for _ in range(3):
        t = feed(watch, t, 5.0, {30: 10, 32: 4})
        watch.check(t)
    assert watch.reasserts == 2                           # bounded
    t = feed(watch, t, 5.0, {30: 10, 32: 10})             # back to the asked rate: reset
    assert watch.check(t) == []
    t = feed(watch, t, 5.0, {30: 10, 32: 4})
    assert watch.check(t) == [32] and watch.reasserts == 3


def test_no_check_before_a_window_has_passed():
    watch = StreamRateWatch({30: 10.0}, window_s=5.0, min_fraction=0.5, max_reasserts=2)
    watch.restart(0.0)
    assert watch.check(4.0) == []


class _FakeLink:
    """What Service touches of a MavlinkLink here: its wall clock and send."""

    def __init__(self) -> None:
        self.sent: list = []
        self.on_sent = self.on_connect = None

    def now_us(self) -> int:
        return 0                     # the wall clock stands still: only vehicle time moves

    def send(self, msg) -> None:
        self.sent.append(msg)


def test_in_lockstep_the_notice_limit_runs_on_vehicle_time():
    import asyncio

    from companion.mavlink import codec
    from companion.config.service import load_config
    from companion.daemon.lockstep import VehicleLinkClock
    from companion.daemon.service import Service

    async def body():
        config = load_config("config/companion.yaml")
        clock = VehicleLinkClock(1.0, base_unix_s=0.0)
        link = _FakeLink()
        service = Service(config, link, None, None, clock)
        repeat_s = config.safety.statustext_repeat_s
        notice = codec.Notice(codec.SEVERITY_INFO, "companion: same text")
        for k in range(3):                   # three repeat intervals apart in vehicle time
            clock.observe(codec.LocalPosition(1, 1, k * (repeat_s + 0.5), 0.0, 0.0, 0.0, 0.0))
            service._send_notice(notice)
        return len(link.sent), service.notices.suppressed
    assert asyncio.run(body()) == (3, 0)


class _Received:
    def __init__(self, msg) -> None:
        self.msg, self.t_us = msg, 0


def test_off_lockstep_too_the_notice_limit_runs_on_vehicle_time():
    """A stub free-running at --speedup 20 (or any vehicle whose clock outruns the wall's):
    the wall clock stands still here while the vehicle's moves; notices a repeat interval apart
    in vehicle time all go out, and a burst in one vehicle second is still capped."""
    import asyncio

    from pymavlink.dialects.v20 import ardupilotmega as mavlink

    from companion.mavlink import codec
    from companion.config.service import load_config
    from companion.daemon.service import Service

    encoder = mavlink.MAVLink(None, srcSystem=1, srcComponent=1)

    async def body():
        config = load_config("config/companion.yaml")
        link = _FakeLink()
        service = Service(config, link, None, None, None)
        repeat_s = config.safety.statustext_repeat_s
        notice = codec.Notice(codec.SEVERITY_INFO, "companion: same text")
        for k in range(3):
            msg = mavlink.MAVLink_local_position_ned_message(
                int(k * (repeat_s + 0.5) * 1000), 0.0, 0.0, 0.0, 0.0, 0.0, 0.0)
            msg.pack(encoder)
            await service._handle(_Received(msg))
            service._send_notice(notice)
        repeated = len([m for m in link.sent if m.get_type() == "STATUSTEXT"])
        burst = [codec.Notice(codec.SEVERITY_INFO, f"companion: text {k}") for k in range(10)]
        for item in burst:
            service._send_notice(item)
        return repeated, service.notices.suppressed, config.safety.statustext_per_s
    repeated, suppressed, per_s = asyncio.run(body())
    # on the (frozen) wall clock only the first would have gone out; the burst shares its
    # vehicle second with the third repeat, so per_s - 1 of it go out
    assert repeated == 3 and suppressed == 10 - (per_s - 1)
