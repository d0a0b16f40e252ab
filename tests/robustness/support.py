"""Helpers of the robustness suite: the recorded stream, and the invariants every case checks."""
from __future__ import annotations

import copy
import dataclasses
import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from companion.mavlink import codec
from companion.config.service import load_config
from companion.onboard.pipeline import Pipeline


@dataclass(frozen=True)
class Recording:
    """Inbound packets of a real flight, as the daemon received them: (t_us, packet bytes)."""
    packets: list[tuple[int, bytes]]
    config_path: Path

    def messages(self) -> list[tuple[float, object]]:
        """(link time s, pymavlink message), parsed afresh (messages are mutable)."""
        parser = codec.Parser()
        out = []
        for t_us, packet in self.packets:
            out.append((t_us / 1e6, parser.decode_packet(packet)))
        return out


def fresh_pipeline(recording: Recording, **link) -> Pipeline:
    """A new pipeline with the recorded flight's config (``link`` keys overridden)."""
    config = load_config(recording.config_path)
    config = dataclasses.replace(config, link=dataclasses.replace(config.link, **link))
    return Pipeline(config, config.goal, record_track=False)


def clone(pipeline: Pipeline) -> Pipeline:
    return copy.deepcopy(pipeline)


def check_outputs(outputs: list, max_speed_mps: float) -> None:
    """No setpoint outside the configured limits; every published pose finite, PSD."""
    for out in outputs:
        if isinstance(out, codec.VelocitySetpoint):
            values = (out.t_s, out.vel_north_mps, out.vel_east_mps, out.yaw_rad)
            assert all(math.isfinite(v) for v in values), out
            assert math.hypot(out.vel_north_mps, out.vel_east_mps) <= max_speed_mps + 1e-9, out
            assert -math.pi <= out.yaw_rad <= math.pi, out
        elif isinstance(out, codec.PoseEstimate):
            cov = np.array(out.cov)
            assert all(math.isfinite(v) for v in (out.t_s, out.north_m, out.east_m, out.yaw_rad))
            assert_psd(cov)


def assert_psd(cov: np.ndarray) -> None:
    assert np.all(np.isfinite(cov)), cov
    scale = max(1.0, float(np.abs(cov).max()))
    assert np.allclose(cov, cov.T, atol=1e-9 * scale), "covariance not symmetric"
    assert np.linalg.eigvalsh(0.5 * (cov + cov.T)).min() >= -1e-9 * scale, "covariance not PSD"


def check_estimate(pipeline: Pipeline) -> None:
    """The estimate is finite and its covariance positive semi-definite."""
    nav = pipeline.navigator
    if nav is None:
        return
    assert np.all(np.isfinite(nav.slam.mean)), nav.slam.mean
    assert_psd(nav.slam.cov)


def rejections(pipeline: Pipeline) -> dict:
    """Everything the pipeline and its navigator counted as refused, by kind."""
    out = {f"pipeline {k}": v for k, v in pipeline.counters.items()}
    if pipeline.navigator is not None:
        out.update({f"navigator {k}": v for k, v in pipeline.navigator.rejected.items()})
    return out
