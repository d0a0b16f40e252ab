"""Writing and printing run reports (shared by simulate, demo, replay and campaigns)."""
from __future__ import annotations

from typing import TextIO

from companion.daemon.json_report import write_json  # noqa: F401  (re-exported for the tools and cli)


def _fmt(value, unit: str = "") -> str:
    if value is None:
        return "n/a"
    if isinstance(value, float):
        return f"{value:.2f}{unit}"
    return f"{value}{unit}"


def print_summary(report: dict, out: TextIO) -> None:
    """A short human summary of a report's aggregate."""
    agg = report["aggregate"]
    clear = agg.get("min_clearance_m", {})
    err = agg.get("final_position_error_m", {})
    lines = [
        f"runs: {agg.get('runs')}   success rate: {_fmt(agg.get('success_rate'))}"
        f"   collision rate: {_fmt(agg.get('collision_rate'))}"
        + (f"   (success: arrived, never within 0.95 d, d = {agg['safety_distance_m']:.2f} m)"
           if "safety_distance_m" in agg else ""),
        f"closest approach to an obstacle centre (a wall's or building's surface): "
        f"min {_fmt(clear.get('min'), ' m')}, "
        f"p5 {_fmt(clear.get('p5'), ' m')}, median {_fmt(clear.get('median'), ' m')}",
        f"final position error: median {_fmt(err.get('median'), ' m')}, "
        f"p95 {_fmt(err.get('p95'), ' m')}, max {_fmt(err.get('max'), ' m')}",
    ]
    surface = agg.get("min_surface_clearance_m")
    if surface:
        lines.append(f"closest approach to any surface: min {_fmt(surface.get('min'), ' m')}, "
                     f"p5 {_fmt(surface.get('p5'), ' m')}, "
                     f"median {_fmt(surface.get('median'), ' m')}")
    arrivals = agg.get("arrivals")
    if arrivals and arrivals.get("max_true_goal_distance_m") is not None:
        lines.append(f"arrivals declared: {arrivals['declared']}, uncertain (held): "
                     f"{arrivals['uncertain']}; truth at most "
                     f"{arrivals['max_true_goal_distance_m']:.2f} m from the goal")
    forest = agg.get("forest")
    if forest:
        lines.append(f"forest: {forest['density_per_ha']:.0f} trees per ha drawn (target "
                     f"{forest['target_density_per_ha']:.0f}, the clearings at start and goal "
                     f"counted), nearest neighbour mean {forest['mean_nearest_neighbour_m']:.2f} m, "
                     f"min {forest['min_nearest_neighbour_m']:.2f} m (Poisson disc "
                     f"{forest['min_spacing_m']:g} m), {forest['corridor_width_m']:g} m x "
                     f"{forest['leg_m']:g} m")
    nees = agg.get("nees")
    if nees and nees.get("mean") is not None:
        lo, hi = nees["band"]
        lines.append(f"pose NEES: mean {nees['mean']:.2f} (3 dof), in the 95% band "
                     f"[{lo:.2f}, {hi:.2f}] on {100 * nees['in_band_fraction']:.0f}% of steps")
    out.write("\n".join(lines) + "\n")
