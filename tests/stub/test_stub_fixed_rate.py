"""`sitl-stub --fixed-rate MSG_ID:HZ`: a message at that rate on every link whatever is asked (a
router or ground station holding the rates, a slow link), the requests still acknowledged."""
from sitl_stub.params import ParamTable
from sitl_stub.streams import LinkSchedulers, MSG_ATTITUDE, MSG_LOCAL_POSITION_NED


def test_a_fixed_rate_holds_against_every_request_on_every_link():
    schedulers = LinkSchedulers(ParamTable())
    schedulers.shared.fixed_s[MSG_LOCAL_POSITION_NED] = 0.5            # 2 Hz
    own = schedulers.for_link("companion")
    assert own.set_message_interval(MSG_LOCAL_POSITION_NED, 1e5)       # accepted ...
    assert own.request_data_stream(6, 50, True)
    for scheduler in (own, schedulers.shared):                           # ... and nothing changes
        assert scheduler.interval_s(MSG_LOCAL_POSITION_NED) == 0.5
    assert own.set_message_interval(MSG_ATTITUDE, 1e5) and own.interval_s(MSG_ATTITUDE) == 0.1
    due = [t / 10 for t in range(0, 41) if MSG_LOCAL_POSITION_NED in own.due(t / 10)]
    assert due == [0.0, 0.5, 1.0, 1.5, 2.0, 2.5, 3.0, 3.5, 4.0]
