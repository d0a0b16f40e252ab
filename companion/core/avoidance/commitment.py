"""Commitment to a side, kept by progress toward the goal, not by time (issue 16, item 3).

Once the goal heading is blocked the vehicle takes a side (left or right of the goal direction),
as a bug algorithm follows a wall. Releasing that side as soon as the goal heading looks free
makes it dither at the mouth of a cul-de-sac: backing out of a U, the goal heading points
into the U again, looks free over the few seconds of look-ahead, and the vehicle turns back in.
Here the side is kept until the vehicle has made progress (it is ``progress_m`` nearer the goal
than where it took the side) or the goal heading is clear much farther ahead
(``clear_reach_m``: the whole way back into the U is then blocked by its bottom). The other side
is taken only when the committed one has nothing flyable (the velocity choice's side penalty:
shown impassable). Pure; distances in metres.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, replace


@dataclass(frozen=True)
class Commitment:
    side: int = 0                    # -1 left, +1 right, 0 none
    taken_at_m: float = math.inf     # the goal distance when the side was taken

    def progressed(self, goal_distance_m: float, progress_m: float) -> bool:
        return goal_distance_m <= self.taken_at_m - progress_m

    def goal_reach_m(self, goal_distance_m: float, progress_m: float,
                     clear_reach_m: float) -> float | None:
        """How far the goal heading must be clear to be taken: None (the usual look-ahead) when
        not committed or once progress is made, else ``clear_reach_m`` (at most the goal)."""
        if self.side == 0 or self.progressed(goal_distance_m, progress_m):
            return None
        return min(clear_reach_m, goal_distance_m)

    def after(self, chosen_side: int, goal_distance_m: float) -> "Commitment":
        """The commitment after a decision that chose ``chosen_side`` (0: the goal heading)."""
        if chosen_side == 0:
            return Commitment()
        if self.side == 0:
            return Commitment(chosen_side, goal_distance_m)
        if chosen_side != self.side:                  # the committed side was impassable
            return replace(self, side=chosen_side)
        return self
