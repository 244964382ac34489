"""``random_bounce``: the study's random motion (§2.2.1, §5.2.3), the way consumer robots clean.

Drive straight at full speed until the bumper fires, then turn on the spot by a random angle
(uniform in ±[``min_turn``, π]) and drive on. The bumper fires on a new contact event
(``info["collisions"]`` or, in a team, ``info["robot_collisions"]`` grows) or when the robot
stalls (its measured forward speed, the first entry of the observation's ``velocity`` part, stays
under a third of the command: pressed against a wall). It uses no lidar. Seeded from the episode
seed and the robot's index.
"""

from __future__ import annotations

import math

import numpy as np

from cabinbench.agents import Baseline, EpisodeContext
from cabinbench.sim.physics import TIME_STEP
from cabinbench.values import is_real_number


class RandomBounce(Baseline):
    name = "random_bounce"

    def __init__(self, min_turn: float = math.pi / 4, **config):
        if not (is_real_number(min_turn) and 0 <= min_turn <= math.pi):
            raise ValueError(f"min_turn must be an angle in radians from 0 to pi, got {min_turn!r}")
        super().__init__(min_turn=min_turn, **config)
        self.min_turn = min_turn

    def reset(self, context: EpisodeContext, observation: np.ndarray, info: dict) -> None:
        super().reset(context, observation, info)
        self.rng = np.random.default_rng([context.seed, context.agent])
        self.turn_left = 0.0  # radians still to turn; the sign gives the direction
        self.collisions = info.get("collisions", 0) + info.get("robot_collisions", 0)
        self.driving_steps = 0

    def act(self, observation: np.ndarray, info: dict) -> np.ndarray:
        robot = self.context.layout.robot
        collisions = info.get("collisions", 0) + info.get("robot_collisions", 0)  # walls or team mates
        bumped = collisions > self.collisions
        forward_speed = observation[self.context.observation_layout["velocity"]][0]
        stalled = self.driving_steps > 2 and forward_speed < 1 / 3
        self.collisions = collisions
        if self.turn_left == 0.0 and (bumped or stalled):
            magnitude = self.rng.uniform(self.min_turn, math.pi)
            self.turn_left = magnitude if self.rng.random() < 0.5 else -magnitude
        if self.turn_left != 0.0:
            self.driving_steps = 0
            step_turn = robot.max_turn_rate * TIME_STEP  # radians per env step at full turn rate
            turn = math.copysign(min(abs(self.turn_left), step_turn), self.turn_left)
            self.turn_left = 0.0 if abs(self.turn_left) <= step_turn else self.turn_left - turn
            return np.array([0.0, turn / step_turn])
        self.driving_steps += 1
        return np.array([1.0, 0.0])


class RandomBounceStudy(RandomBounce):
    """``random_bounce_study``: random motion as the study describes it (§2.2.1: "moves forwards until
    collision occurs, then turns its heading with a random degree"), so any new heading, uniform in
    ±[0, π], where ``random_bounce`` turns at least π/4 (a turn of a few degrees only meets the same
    wall again). The study ran it for 3000 steps (§5.2.3): record it with ``--max-steps 3000``, as
    ``scripts/make_results.sh`` does. Its steps were Unity's 0.02 s and ours are 0.1 s, so 3000 steps
    here are 300 s of driving against the study's 60 s; the paper's reproduction report gives both.
    """

    name = "random_bounce_study"

    def __init__(self, min_turn: float = 0.0, **config):
        super().__init__(min_turn=min_turn, **config)
