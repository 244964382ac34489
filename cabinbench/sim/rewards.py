"""Reward presets, selected by name from :data:`REWARD_PRESETS`. Each maps one robot's step events
to a float.

``paper`` reproduces the study's Tables 4.4 and 4.5: new goal marker +0.5, obstacle (or robot)
hit -0.3, bound -10, step -0.01, exit landmark reached +2, and on the step that clears a cell
the reward is *set* to 3 (ML-Agents' ``SetReward``: it replaces that step's other terms).

``coverage`` is dense: +10 × the newly covered fraction of the coverable area (a whole episode
is worth at most 10), collision -0.1, bound -1, step -0.005, cell cleared +1, exit +0.5.

For teams both are given per robot on its own events; cell clearing is a team event paid to
every robot, and ``coverage`` pays each robot for the team's new area as well as its own
(``team_weight`` of it), so helping the team counts.

Adding a preset is one function with :func:`paper`'s signature and one ``@register_preset("name")`` above
it; the envs and the ``--reward`` choices of ``python -m cabinbench.run`` take it from there.
"""

from __future__ import annotations

from collections.abc import Callable

from cabinbench.sim.events import StepEvents

RewardFunction = Callable[[StepEvents, int, int, float], float]


class Presets(dict):
    """Name → reward function; printed as the names, for error messages."""

    def __str__(self) -> str:
        return ", ".join(self)


REWARD_PRESETS: dict[str, RewardFunction] = Presets()


def register_preset(name: str) -> Callable[[RewardFunction], RewardFunction]:
    """Register the decorated function as the reward preset ``name``."""

    def register(function: RewardFunction) -> RewardFunction:
        REWARD_PRESETS[name] = function
        return function

    return register


@register_preset("paper")
def paper(events: StepEvents, robot: int, coverable_pixels: int, team_weight: float) -> float:
    mine = events.robots[robot]
    if events.cells_cleared:
        return 3.0
    return (
        0.5 * mine.goals_reached
        - 0.3 * (mine.collisions + mine.robot_collisions)
        - 10.0 * mine.bound_violations
        - 0.01
        + 2.0 * mine.exits_reached
    )


@register_preset("coverage")
def coverage(events: StepEvents, robot: int, coverable_pixels: int, team_weight: float) -> float:
    mine = events.robots[robot]
    new_fraction = mine.new_coverable_pixels / coverable_pixels
    if len(events.robots) > 1:
        new_fraction += team_weight * events.team_new_coverable_pixels / coverable_pixels
    return (
        10.0 * new_fraction
        - 0.1 * (mine.collisions + mine.robot_collisions)
        - 1.0 * mine.bound_violations
        - 0.005
        + 1.0 * events.cells_cleared
        + 0.5 * mine.exits_reached
    )


def reward(
    preset: str, events: StepEvents, robot: int, coverable_pixels: int, team_weight: float = 0.5
) -> float:
    """The reward of ``robot`` for one step under the named preset."""
    if preset not in REWARD_PRESETS:
        raise ValueError(f"unknown reward preset {preset!r}; choose one of {REWARD_PRESETS}")
    return REWARD_PRESETS[preset](events, robot, coverable_pixels, team_weight)
