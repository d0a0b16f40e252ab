"""Replay compares setpoints and poses as the wire carries them (float32) without packing each
one: the shortcuts must equal pack-then-parse exactly."""
import math

import numpy as np

from companion.mavlink import codec


def test_setpoint_key_shortcut_equals_pack_then_parse():
    rng = np.random.default_rng(3)
    encoder, parser = codec.Encoder(1, 191), codec.Parser()
    for _ in range(500):
        sp = codec.VelocitySetpoint(1, 1, float(rng.uniform(0, 4e4)), float(rng.normal(0, 5)),
                                    float(rng.normal(0, 5)), float(rng.uniform(-math.pi, math.pi)),
                                    "goal")
        wire = parser.decode_packet(encoder.encode(codec.set_position_target(sp)))
        assert codec.setpoint_key_of(sp) == codec.setpoint_key(wire)


def test_pose_shortcut_equals_the_odometry_wire_values():
    rng = np.random.default_rng(4)
    encoder, parser = codec.Encoder(1, 191), codec.Parser()
    for _ in range(200):
        cov = np.diag(rng.uniform(0.01, 1.0, 3))
        pose = codec.PoseEstimate(float(rng.uniform(0, 4e3)), float(rng.normal(0, 300)),
                                  float(rng.normal(0, 300)), float(rng.uniform(-3, 3)),
                                  tuple(map(tuple, cov)), 0)
        wire = parser.decode_packet(encoder.encode(codec.odometry(pose)))
        assert wire.time_usec == int(round(pose.t_s * 1e6))
        assert (wire.x, wire.y) == (codec.float32(pose.north_m), codec.float32(pose.east_m))
