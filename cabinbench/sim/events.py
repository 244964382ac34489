"""What happened in one step of the world, robot by robot: the protocol and the physics fill it,
the rewards and the metrics read it."""

from __future__ import annotations

from dataclasses import dataclass


@dataclass(slots=True)
class RobotEvents:
    """What happened to one robot during one step."""

    collisions: int = 0
    robot_collisions: int = 0
    bound_violations: int = 0
    goals_reached: int = 0
    exits_reached: int = 0
    new_coverable_pixels: int = 0
    distance: float = 0.0
    rotation: float = 0.0


@dataclass(slots=True)
class StepEvents:
    robots: list[RobotEvents]
    cells_cleared: int = 0  # cells cleared during this step (team)
    success: bool = False  # the layout's success criterion holds after this step

    @property
    def team_new_coverable_pixels(self) -> int:
        return sum(r.new_coverable_pixels for r in self.robots)
