"""The stub's depth cameras (sensor.form depth): frames at the camera's own rate, rendered from
the TRUE pose (interpolated between the physics steps around each frame's time, with the step's
thrust tilt) by depth_render.py, one per mount of sensor.cameras."""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from .depth_config import DepthSpec
from .depth_render import StubRenderer, to_z16
from .telemetry import time_boot_ms
from .world import wrap_pi


@dataclass(frozen=True)
class StubDepthFrame:
    frame_number: int
    time_boot_ms: int
    camera_id: int
    spec: DepthSpec
    pixels: np.ndarray          # (H, W) uint16 millimetres, 0 = no data


class DepthRig:
    """The scenario's cameras and their frame clock. ``frames_due(sim)`` after every step (and
    once before the first): the frames whose times fall in (the step before, now]."""

    def __init__(self, sim, rng: np.random.Generator) -> None:
        sensor = sim.scenario.sensor
        self.spec: DepthSpec = sensor.depth
        self.mounts = sensor.cameras
        self.rng = rng
        self.period_s = 1.0 / self.spec.rate_hz
        self.renderer = StubRenderer(self.spec)
        self.next_frame = 0
        world = sim.scenario.world
        self.outlines = [(list(shape.outline), shape.base_m,
                          math.inf if shape.height_m is None else shape.height_m)
                         for shape in world.shapes]
        self.obstacles = world.obstacles

    def frames_due(self, sim) -> list[StubDepthFrame]:
        now, before = sim.truth, sim.previous_truth
        t_now = sim.t_s
        t_before = t_now - sim.dt_s if sim.step_index > 0 else t_now
        frames: list[StubDepthFrame] = []
        while self.next_frame * self.period_s <= t_now + 1e-9:
            t_frame = self.next_frame * self.period_s
            w = 1.0 if t_now <= t_before else min(1.0, max(0.0, (t_frame - t_before)
                                                          / (t_now - t_before)))
            north = before.north_m + w * (now.north_m - before.north_m)
            east = before.east_m + w * (now.east_m - before.east_m)
            up = before.up_m + w * (now.up_m - before.up_m)
            yaw = wrap_pi(before.yaw_rad + w * wrap_pi(now.yaw_rad - before.yaw_rad))
            frames += self.render(t_frame, self.next_frame, north, east, up, *sim.tilt_rad, yaw)
            self.next_frame += 1
        return frames

    def render(self, t_s: float, number: int, north: float, east: float, up: float,
               roll: float, pitch: float, yaw: float) -> list[StubDepthFrame]:
        posts = []
        for ob in self.obstacles:
            n, e = ob.position_at(t_s)
            posts.append((n, e, ob.radius_m, ob.base_m,
                          math.inf if ob.height_m is None else ob.height_m))
        out = []
        for camera_id, mount in enumerate(self.mounts):
            depth = self.renderer.ranges(north, east, up, roll, pitch, yaw, mount, posts,
                                         self.outlines)
            out.append(StubDepthFrame(number, time_boot_ms(t_s), camera_id, self.spec,
                                      to_z16(depth, self.spec, self.rng)))
        return out
