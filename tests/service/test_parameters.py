"""The parameter table, the sans-I/O parameter server, the safe point and the overlay file."""
import math

import pytest

from companion.onboard import health
from companion.mavlink import codec, param_codec
from companion.config.service import load_config
from companion.core.estimation.slam_types import Observation
from companion.daemon.param_overlay import apply_overlay, overlay_path, write_overlay
from companion.onboard.parameters import (MAV_PARAM_TYPE_INT32, MAV_PARAM_TYPE_REAL32, TABLE, ParamChange,
                                  ParamRequest, ParamServer, ParamValue)
from companion.onboard.pipeline import Pipeline
from tests.service.test_pipeline import GOAL, Feed, config, hb

US, GCS = (1, 191), (255, 190)


def server(**kw):
    return ParamServer(load_config("config/companion.yaml"), **kw)


def request(kind, name="", value=math.nan, param_type=MAV_PARAM_TYPE_REAL32, index=-1,
            target=US, signed=False):
    return ParamRequest(kind, *GCS, *target, name=name, index=index, value=value,
                        param_type=param_type, signed=signed)


def handle(srv, req, t_s=1.0):
    return srv.handle(req, *US, t_s)


def test_the_table_names_fit_mavlink_and_each_maps_to_a_config_key():
    cfg = load_config("config/companion.yaml")
    names = [spec.name for spec in TABLE]
    assert len(set(names)) == len(names)
    for spec in TABLE:
        assert 0 < len(spec.name) <= 16 and spec.name.startswith("CA_")
        section, key = spec.key.split(".")
        value = getattr(getattr(cfg, section), key)          # the key exists in the config
        wire = spec.to_wire(value)
        assert math.isfinite(wire) and spec.from_wire(wire) == value
        assert spec.param_type in (MAV_PARAM_TYPE_REAL32, MAV_PARAM_TYPE_INT32)


def test_the_list_is_complete_with_count_and_index():
    out = handle(server(), request("list", target=(1, 0)))
    assert [r.index for r in out.replies] == list(range(len(TABLE)))
    assert {r.count for r in out.replies} == {len(TABLE)}
    assert out.replies[0].name == "CA_SAFE_DIST"
    assert out.replies[0].value == load_config("config/companion.yaml").avoidance.safety_distance_m


def test_read_by_name_and_by_index_and_another_component_is_not_answered():
    srv = server()
    by_name = handle(srv, request("read", "CA_ETA")).replies
    by_index = handle(srv, request("read", index=by_name[0].index)).replies
    assert by_name == by_index and by_name[0].name == "CA_ETA"
    assert handle(srv, request("list", target=(1, 1))).replies == []      # the autopilot's
    assert handle(srv, request("list", target=(2, 191))).replies == []    # another system


def test_a_set_in_range_is_echoed_stored_and_live_in_the_running_config():
    srv = server()
    out = handle(srv, request("set", "CA_SAFE_DIST", 12.0))
    assert out.replies == [ParamValue("CA_SAFE_DIST", 12.0, MAV_PARAM_TYPE_REAL32, len(TABLE), 0)]
    assert out.change.live and out.change.new == 12.0
    assert out.change.old == load_config("config/companion.yaml").avoidance.safety_distance_m
    assert out.change.config.avoidance.safety_distance_m == 12.0
    assert srv.running.avoidance.safety_distance_m == 12.0


def test_a_next_start_set_is_stored_but_not_running():
    srv = server()
    out = handle(srv, request("set", "CA_STRATEGY", 0.0, MAV_PARAM_TYPE_INT32))
    assert out.change is not None and not out.change.live and out.change.config is None
    assert srv.stored.avoidance.strategy == "cone" and srv.running.avoidance.strategy == "union"
    assert "next start" in out.notices[0].text


@pytest.mark.parametrize("req, kind", [
    (request("set", "CA_SAFE_DIST", 500.0), "out of range"),
    (request("set", "CA_SAFE_DIST", math.nan), "not finite"),
    (request("set", "CA_SAFE_DIST", math.inf), "not finite"),
    (request("set", "CA_SAFE_DIST", 12.0, MAV_PARAM_TYPE_INT32), "wrong type"),
    (request("set", "CA_STRATEGY", 0.5, MAV_PARAM_TYPE_INT32), "wrong type"),
    (request("set", "CA_STRATEGY", 7.0, MAV_PARAM_TYPE_INT32), "out of range"),
    (request("set", "CA_CRUISE_SPD", 20.0), "invalid config"),     # above max_speed_mps 8
    (request("set", "CA_GOAL_LOOK", 60.0), "invalid config"),      # beyond half the 90 deg view
])
def test_each_refusal_answers_the_old_value_says_why_and_is_counted(req, kind):
    srv = server()
    before = srv.value_of(srv.by_name[req.name])
    out = handle(srv, req)
    assert out.change is None and out.replies == [before]
    assert out.notices[0].severity == "warning" and req.name in out.notices[0].text
    assert len(out.notices[0].text) <= 50                 # one STATUSTEXT, not cut
    assert srv.refused == {kind: 1} and srv.stored == srv.running == load_config(
        "config/companion.yaml")


def test_unknown_names_refused_when_addressed_ignored_on_a_broadcast():
    srv = server()
    out = handle(srv, request("set", "\ufffdGARBAGE", 1.0))
    assert out.replies == [] and srv.refused == {"unknown name": 1} and out.notices
    out = handle(srv, request("set", "WPNAV_SPEED", 1.0, target=(1, 0)))   # the autopilot's
    assert out.replies == [] and out.notices == [] and srv.ignored == 1


def test_unsigned_set_refused_when_signing_is_required():
    srv = server(require_signed=True)
    assert handle(srv, request("set", "CA_SAFE_DIST", 12.0)).change is None
    assert srv.refused == {"unsigned": 1}
    assert handle(srv, request("set", "CA_SAFE_DIST", 12.0, signed=True)).change is not None


def test_the_codec_round_trips_param_messages():
    mav = codec.make_mavlink(255, 190)
    msg = mav.param_set_encode(1, 191, b"CA_SAFE_DIST", 12.0, MAV_PARAM_TYPE_REAL32)
    msg = mav.parse_char(msg.pack(mav))
    event = codec.decode(msg)
    assert event == ParamRequest("set", 255, 190, 1, 191, name="CA_SAFE_DIST", value=12.0,
                                 param_type=MAV_PARAM_TYPE_REAL32)
    out = param_codec.param_value(ParamValue("CA_SAFE_DIST", 12.0, MAV_PARAM_TYPE_REAL32, 13, 0))
    assert (out.param_id, out.param_value, out.param_count, out.param_index) == \
        ("CA_SAFE_DIST", 12.0, 13, 0)


# ------------------------------------------------------------ the pipeline's safe point
def flying():
    feed = Feed(Pipeline(config(require_camera=False), GOAL, record_track=True))
    feed.send(hb())
    feed.send(codec.ObstacleFrame(1, 100, feed.t_s, ()))
    for _ in range(20):
        feed.step()
    return feed


def test_a_live_set_waits_for_the_end_of_a_camera_frame_then_guidance_follows():
    feed = flying()
    p = feed.p
    before = p.navigator.params.safety_distance_m
    feed.camera([Observation(30.0, 0.2, 5)])           # a frame in assembly
    out = feed.send(request("set", "CA_SAFE_DIST", before + 2.0))
    assert any(isinstance(o, ParamChange) for o in out)
    assert any(isinstance(o, ParamValue) for o in out)
    assert p.navigator.params.safety_distance_m == before      # queued, not mid-frame
    feed.camera([Observation(40.0, -0.2, 6)])          # the same frame continues: still queued
    assert p.navigator.params.safety_distance_m == before and p.frames.assembly is not None
    feed.step()                                        # the frame's decision, then the safe point
    assert p.navigator.params.safety_distance_m == before + 2.0
    assert p.config.avoidance.safety_distance_m == before + 2.0
    assert p.counters["param_applied"] == 1


def test_a_next_start_set_does_not_touch_the_flight():
    feed = flying()
    p = feed.p
    nav_params = p.navigator.params
    feed.send(request("set", "CA_MAX_SPD", 6.0))
    feed.step()
    assert p.config.commanding.max_speed_mps == 8.0 and p.navigator.params == nav_params
    assert p.params.stored.commanding.max_speed_mps == 6.0


def test_health_follows_commanding_and_camera():
    feed = flying()
    judged = health.assess(feed.p.health_inputs(feed.link_s))
    assert judged.state == "active" and judged.avoidance_enabled and judged.avoidance_healthy
    feed.armed = False
    feed.step(heartbeat=hb(armed=False))
    assert health.assess(feed.p.health_inputs(feed.link_s)).state == "standby"
    feed.p.handle(feed.link_s + 60.0, None)           # the vehicle's heartbeat long gone
    judged = health.assess(feed.p.health_inputs(feed.link_s + 60.0))
    assert judged.state == "critical" and judged.system_status == health.MAV_STATE_CRITICAL


@pytest.mark.parametrize("inputs, state, healthy", [
    (dict(vehicle_found=False, commanding=False), "standby", True),
    (dict(commanding=True), "active", True),
    (dict(commanding=True, safe_reason="obstacle data stale", camera_live=False), "critical",
     False),
    (dict(commanding=False, safe_reason="obstacle data stale", camera_live=False), "standby",
     False),
    (dict(commanding=True, estimator_state="lost"), "active", False),
    (dict(link_lost=True, commanding=False), "critical", True),
])
def test_health_states_and_the_avoidance_bit(inputs, state, healthy):
    base = dict(vehicle_found=True, link_lost=False, commanding=False, safe_reason=None,
                deciding=True, camera_live=True, estimator_state="ok")
    judged = health.assess(health.HealthInputs(**{**base, **inputs}))
    assert (judged.state, judged.avoidance_healthy) == (state, healthy)
    assert len(judged.describe()) <= 50


# ------------------------------------------------------------ the overlay file
def test_the_overlay_round_trips_and_a_bad_value_names_the_file_and_key(tmp_path):
    cfg = load_config("config/companion.yaml")
    path = overlay_path(tmp_path / "site.yaml")
    assert path.name == "site.params.yaml"
    write_overlay(path, {"avoidance.safety_distance_m": 12.0})
    applied, overlay = apply_overlay(cfg, path)
    assert applied.avoidance.safety_distance_m == 12.0 and overlay.error is None
    write_overlay(path, {"avoidance.safety_distance_m": -1.0})
    applied, overlay = apply_overlay(cfg, path)
    assert applied == cfg
    assert str(path) in overlay.error and "avoidance.safety_distance_m" in overlay.error


@pytest.mark.parametrize("text", ["avoidance: [1, 2\n", "avoidance:\n  horizon_sx: 3\n",
                                  "link:\n  component_id: 5\n", "\xff\xfe", "- 1\n"])
def test_a_corrupt_overlay_is_reported_and_ignored(tmp_path, text):
    cfg = load_config("config/companion.yaml")
    path = tmp_path / "site.params.yaml"
    path.write_bytes(text.encode("latin-1"))
    applied, overlay = apply_overlay(cfg, path)
    assert applied == cfg and overlay.error is not None and str(path) in overlay.error


def test_with_signing_on_an_unsigned_param_set_never_reaches_the_server():
    """The link's parser refuses unsigned traffic when signing is on (adapters/codec.py Parser):
    an unsigned PARAM_SET is counted as signature_rejected; a signed one passes, marked signed."""
    key = bytes(range(32))
    parser = codec.Parser(signing_key=key, unix_s=1.8e9)
    unsigned = codec.make_mavlink(255, 190)
    packet = unsigned.param_set_encode(1, 191, b"CA_SAFE_DIST", 12.0, 9).pack(unsigned)
    assert parser.feed(packet) == [] and parser.signature_rejected == 1
    signer = codec.Encoder(255, 190, signing_key=key, unix_s=1.8e9)
    packet = signer.encode(codec.mavlink.MAVLink_param_set_message(1, 191, b"CA_SAFE_DIST", 12.0, 9))
    (msg,) = parser.feed(packet)
    assert codec.decode(msg).signed


def test_a_set_checks_the_same_rules_as_the_typed_config_path():
    """with_value (PARAM_SET's path) agrees with apply_values (config_loader.build, the YAML's)
    on every parameter, for a value inside its range and one the config refuses."""
    from companion.errors import ConfigError
    from companion.onboard.parameters import apply_values, with_value
    cfg = load_config("config/companion.yaml")
    for spec in TABLE:
        for wire in (spec.min_value, spec.max_value):
            value = spec.from_wire(wire)
            try:
                fast = with_value(cfg, spec.key, value, "x")
            except ConfigError as exc:
                with pytest.raises(ConfigError) as slow:
                    apply_values(cfg, {spec.key: value}, "x")
                assert str(slow.value) == str(exc)
                continue
            assert fast == apply_values(cfg, {spec.key: value}, "x")
