"""Traffic worlds whose movers all go one speed (issue 33): ``head-on-7`` is the head-on kind
with every mover at 7 m/s instead of uniformly 3 to 5 m/s (worlds.TRAFFIC_SPEED_MPS).

The meeting is drawn as for the kind itself (worlds.traffic_world: same seed, same meeting point
and lateral offset; only the speed, and so the mover's start, differs). An overtaken mover keeps
its cap of 0.6 x the vehicle's cruise speed (at copter.yaml's 5 m/s: 3 m/s): one as fast as the
vehicle is never met, one faster comes from behind the camera. ``overtaking-S`` with S above the
cap is therefore refused here, not flown as a slower world under a misleading name: fly it with
``--speed-mps`` of at least S / 0.6 (see speed_kind_check).
"""
from __future__ import annotations

BASE_KINDS = ("traffic", "head-on", "crossing", "overtaking")
SPEEDS_MPS = (3, 5, 7)
OVERTAKEN_SPEED_FRACTION = 0.6      # worlds.traffic_world's cap on an overtaken mover

# name -> (the traffic kind, the movers' speed in m/s)
SPEED_KINDS = {f"{kind}-{speed}": (kind, float(speed)) for kind in BASE_KINDS
               for speed in SPEEDS_MPS}


def speed_kind_check(kind: str, mover_speed_mps: float, cruise_mps: float) -> None:
    """Refuse an overtaking world whose mover would not be overtaken at this cruise speed."""
    if kind == "overtaking" and mover_speed_mps > OVERTAKEN_SPEED_FRACTION * cruise_mps + 1e-9:
        raise ValueError(
            f"overtaking at {mover_speed_mps:g} m/s needs a cruise speed of at least "
            f"{mover_speed_mps / OVERTAKEN_SPEED_FRACTION:.1f} m/s (the vehicle overtakes a mover "
            f"at most {OVERTAKEN_SPEED_FRACTION:g} x its own speed), got {cruise_mps:g} m/s: "
            f"give --speed-mps")
