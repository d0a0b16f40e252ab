"""The parameter list at a radio's pace: one list at a time, link.param_rate_hz values a second
(companion/onboard/param_pacing.py), on a virtual clock."""
import dataclasses

import pytest

from companion.config.service import load_config
from companion.onboard.param_pacing import MAX_BURST, ParamListPacer
from companion.onboard.parameters import TABLE, ParamRequest, ParamValue
from companion.onboard.pipeline import Pipeline
from tests.service.test_pipeline import GOAL

GCS, US = (255, 190), (1, 191)


def list_request(target=US) -> ParamRequest:
    return ParamRequest("list", *GCS, *target)


def test_one_request_gets_the_whole_list_one_value_a_period():
    pacer = ParamListPacer(10.0)
    assert pacer.request(5.0, list("abc"))
    assert pacer.due(5.0) == ["a"] and pacer.next_due_s == pytest.approx(5.1)
    assert pacer.due(5.05) == []
    assert pacer.due(5.1) == ["b"]
    assert pacer.due(5.2) == ["c"] and not pacer.sending and pacer.next_due_s is None


def test_a_request_while_a_list_is_sent_starts_none_and_the_next_keeps_the_pace():
    pacer = ParamListPacer(10.0)
    pacer.request(0.0, [1, 2])
    assert not pacer.request(0.01, [1, 2]) and pacer.requests_folded == 1
    assert pacer.due(0.0) == [1] and pacer.due(0.1) == [2]
    assert pacer.request(0.1, [1, 2])                    # the list ended: a new one
    assert pacer.due(0.1) == [] and pacer.due(0.2) == [1]   # not before one period has passed
    assert pacer.lists_started == 2


def test_a_late_timer_catches_up_at_most_one_period():
    pacer = ParamListPacer(10.0)
    pacer.request(0.0, list(range(20)))
    pacer.due(0.0)
    assert len(pacer.due(5.0)) == MAX_BURST + 1         # not the 50 it "owes"


def test_the_rate_must_be_positive():
    with pytest.raises(ValueError, match="rate_hz"):
        ParamListPacer(0.0)


def storm(pipeline: Pipeline, requests: int, duration_s: float, tick_s: float):
    """``requests`` PARAM_REQUEST_LISTs spread over ``duration_s`` of link time, the service's
    timer every ``tick_s``: every PARAM_VALUE out, with its link time."""
    sent: list[tuple[float, ParamValue]] = []
    request_times = [k * duration_s / requests for k in range(requests)]
    ticks = int(duration_s / tick_s) + 1
    events = sorted([(t, 0) for t in request_times] + [(k * tick_s, 1) for k in range(ticks)])
    for t_s, kind in events:
        out = pipeline.handle(t_s, list_request()) if kind == 0 else pipeline.param_tick(t_s)
        sent.extend((t_s, o) for o in out if isinstance(o, ParamValue))
    return sent


def test_a_storm_of_500_list_requests_in_30_s_draws_the_paced_rate_only():
    cfg = load_config("config/companion.yaml")
    rate_hz = cfg.link.param_rate_hz
    sent = storm(Pipeline(cfg, GOAL), 500, 30.0, 0.05)
    # before: 500 x 13 = 6,500 values (240 a second); now at most rate x 30 s (+ one value at t=0)
    assert len(sent) <= rate_hz * 30.0 + 1
    assert len(sent) >= 0.9 * rate_hz * 30.0             # and the lists do go out
    for start in range(0, 30):                            # every 1 s window: at most the rate + 1
        in_window = [t for t, _ in sent if start <= t < start + 1.0]
        assert len(in_window) <= rate_hz + 1
    # whole lists, in order: every value of the table, index after index
    indices = [v.index for _, v in sent]
    assert indices[:len(TABLE)] == list(range(len(TABLE)))
    assert all(b == (a + 1) % len(TABLE) for a, b in zip(indices, indices[1:]))


def test_a_single_request_still_gets_the_full_list_at_the_configured_rate():
    cfg = load_config("config/companion.yaml")
    cfg = dataclasses.replace(cfg, link=dataclasses.replace(cfg.link, param_rate_hz=4.0))
    pipeline = Pipeline(cfg, GOAL)
    sent = storm(pipeline, 1, 10.0, 0.01)
    values = [v for _, v in sent]
    assert [v.index for v in values] == list(range(len(TABLE)))
    assert {v.count for v in values} == {len(TABLE)}
    assert values[0].name == "CA_SAFE_DIST"
    assert sent[-1][0] == pytest.approx((len(TABLE) - 1) / 4.0, abs=0.011)   # 4 a second


def test_another_component_s_list_request_starts_nothing():
    pipeline = Pipeline(load_config("config/companion.yaml"), GOAL)
    assert pipeline.handle(0.0, list_request(target=(1, 1))) == []
    assert not pipeline.param_requests.pacer.sending and pipeline.param_tick(1.0) == []
