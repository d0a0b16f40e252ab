"""What the companion says about itself: HEARTBEAT.system_status and SYS_STATUS's avoidance bit.

Pure: the service passes what the pipeline knows (companion/onboard/pipeline.py Pipeline.health_inputs)
and sends what :func:`assess` returns (docs/messages.md, "Identity and health").

- ``standby`` (MAV_STATE_STANDBY): not commanding: on the ground, not armed in GUIDED, or no
  vehicle yet.
- ``active`` (MAV_STATE_ACTIVE): setpoints go out (armed in GUIDED, airborne, guidance as planned).
- ``critical`` (MAV_STATE_CRITICAL): the vehicle's heartbeat was lost, or the safe action holds the
  vehicle while commanding (obstacle data stale, estimator diverged or lost): MAVLink's "a failure
  occurred ... manual intervention" state.

SYS_STATUS bit MAV_SYS_STATUS_OBSTACLE_AVOIDANCE (0x20000000): present always (this component is
the avoidance system); enabled while a goal is set and the estimator runs (the avoidance is
deciding); healthy while the camera is live (an obstacle message within
failsafe.obstacle_timeout_s) and the consistency monitor does not say ``lost``.
"""
from __future__ import annotations

from dataclasses import dataclass

MAV_STATE_STANDBY = 3
MAV_STATE_ACTIVE = 4
MAV_STATE_CRITICAL = 5
STATE_CODES = {"standby": MAV_STATE_STANDBY, "active": MAV_STATE_ACTIVE,
               "critical": MAV_STATE_CRITICAL}


@dataclass(frozen=True)
class HealthInputs:
    vehicle_found: bool
    link_lost: bool                 # the vehicle's heartbeat went stale after being seen
    commanding: bool                # armed, GUIDED, fresh heartbeat, airborne
    safe_reason: str | None         # the safe action is on, and why
    deciding: bool                  # a goal and a running estimator
    camera_live: bool
    estimator_state: str | None     # the consistency monitor: ok / degraded / lost / None


@dataclass(frozen=True)
class Health:
    state: str                      # standby / active / critical
    reason: str
    avoidance_enabled: bool
    avoidance_healthy: bool

    @property
    def system_status(self) -> int:
        return STATE_CODES[self.state]

    def describe(self) -> str:
        """The STATUSTEXT on a change (at most 50 characters with the reason cut)."""
        bit = "healthy" if self.avoidance_healthy else "unhealthy"
        return f"companion: {self.state}, avoidance {bit}: {self.reason}"[:50]


def assess(inputs: HealthInputs) -> Health:
    healthy = inputs.camera_live and inputs.estimator_state != "lost"
    if inputs.link_lost:
        state, reason = "critical", "vehicle heartbeat lost"
    elif inputs.commanding and inputs.safe_reason is not None:
        state, reason = "critical", inputs.safe_reason
    elif inputs.commanding:
        state, reason = "active", "commanding"
    elif not inputs.vehicle_found:
        state, reason = "standby", "no vehicle"
    else:
        state, reason = "standby", "not commanding"
    if state != "critical" and not healthy:
        reason = "camera stale" if not inputs.camera_live else "estimator lost"
    return Health(state, reason, inputs.deciding, healthy)
