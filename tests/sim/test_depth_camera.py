"""companion simulate's depth cameras (companion/sim/depth_camera.py): frames at the camera's own
rate from the truth's 10 Hz steps, rendered with the tilt of the accelerating multicopter, one
per mount; and simulate's JSON states the camera."""
from __future__ import annotations

import dataclasses
import json
import math
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from companion.config.scenario import load_scenario
from companion.sim.truth import TruthWorld

REPO = Path(__file__).resolve().parents[2]


def small(name: str):
    s = load_scenario(REPO / "config" / "scenarios" / name)
    depth = dataclasses.replace(s.sensor.depth, width_px=106, height_px=60)
    return dataclasses.replace(s, sensor=dataclasses.replace(s.sensor, depth=depth))


def test_frames_come_at_15_hz_from_10_hz_steps_with_the_tilt_of_the_acceleration():
    scenario = small("depth.yaml")
    truth = TruthWorld(scenario, np.random.default_rng(0), depth_rng=np.random.default_rng(1))
    frames = truth.capture_depth()                       # t = 0
    truth.vel_ne_mps = np.zeros(2)                       # from rest, then full acceleration
    for _ in range(10):
        truth.step_copter(np.array([10.0, 0.0]), 0.0)
        frames += truth.capture_depth()
    assert [f.frame_number for f in frames] == list(range(16))           # 0 .. 1 s at 15 Hz
    assert [f.time_boot_ms for f in frames] == [round(k * 1000 / 15) for k in range(16)]
    accel = scenario.vehicle.max_accel_mps2
    assert truth.depth_camera.last_pose.pitch_rad == pytest.approx(-math.atan(accel / 9.80665))
    assert frames[0].depth.shape == (60, 106)


def test_one_frame_per_mount_and_the_pitched_camera_sees_the_floor():
    level = TruthWorld(small("depth.yaml"), np.random.default_rng(0),
                       depth_rng=np.random.default_rng(1)).capture_depth()
    pitched = TruthWorld(small("depth-pitched.yaml"), np.random.default_rng(0),
                         depth_rng=np.random.default_rng(1)).capture_depth()
    assert len(level) == len(pitched) == 1
    # at 10 m the level camera's floor is beyond 18 m (the lowest row's ray); pitched 20 deg
    # down the floor fills the lower image from 8.7 m
    assert (pitched[0].depth > 0).mean() > 0.3
    assert (pitched[0].depth > 0).sum() > 2 * (level[0].depth > 0).sum()


def test_simulate_json_states_the_form_and_the_intrinsics(tmp_path):
    out = tmp_path / "o.json"
    done = subprocess.run([sys.executable, "-m", "companion", "simulate", "--scenario",
                           "config/scenarios/depth.yaml", "--runs", "1", "--json", str(out)],
                          cwd=REPO, capture_output=True, text=True, timeout=600)
    assert done.returncode == 0, done.stderr
    sensor = json.loads(out.read_text())["aggregate"]["sensor"]
    assert sensor["form"] == "depth" and sensor["rate_hz"] == 15.0
    assert (sensor["intrinsics"]["width_px"], sensor["intrinsics"]["height_px"]) == (848, 480)
    assert sensor["intrinsics"]["fx_px"] == pytest.approx(446.8, abs=0.1)
    assert sensor["cameras"][0]["pitch_deg"] == 0.0
