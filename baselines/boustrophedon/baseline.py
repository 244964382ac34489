"""``Boustrophedon``: the baseline that plans from the layout and drives the plan through the env's
actions (never by moving the robot).

In ``reset`` it takes its robot's legs (``plan.plan_layout``); in ``act`` a
:class:`~cabinbench.baselines.path_following.PathFollower` turns the current leg's waypoints into
velocity commands from ``info["pose"]``. A leg waits for its start condition: the cell it
follows cleared (``info["cells_cleared"]``) and its delay passed (``info["time"]``). A baseline
sees only its own ``info``, so a team coordinates through its plans and these shared entries.

Safety in a team: a robot whose lidar shows another robot right in front of it stops driving
forward (it may still turn) until the way is clear, for at most ``BLOCKED_PATIENCE`` seconds
(then it drives on rather than wait for ever). The plans make such meetings rare (a robot
catching up with one turning into a pocket).
"""

from __future__ import annotations

import math

import numpy as np
from cabinbench.baselines.boustrophedon.legs import Leg
from cabinbench.baselines.boustrophedon.plan import plan_layout
from cabinbench.baselines.path_following import PathFollower

from cabinbench.agents import Baseline, EpisodeContext
from cabinbench.sim.lidar import LidarConfig
from cabinbench.sim.observation import LIDAR_CHANNELS, lidar_rays
from cabinbench.sim.physics import TIME_STEP

FOLLOW_GAP = 0.12  # metres: stop driving forward when another robot is this close in front
ON_WAYPOINT = 0.05  # metres: a leg whose first waypoint is this close starts at its second
BLOCKED_PATIENCE = 5.0  # seconds a robot waits for a robot in front before it drives on anyway


class Boustrophedon(Baseline):
    name = "boustrophedon"

    def reset(self, context: EpisodeContext, observation: np.ndarray, info: dict) -> None:
        super().reset(context, observation, info)
        self.legs = self.plan(context, info)
        robot = context.layout.robot
        self.follower = PathFollower(
            self.legs[0].waypoints if self.legs else np.zeros((1, 2)),
            robot.max_speed,
            robot.max_turn_rate,
            TIME_STEP,
        )
        self.leg, self.leg_started, self.blocked_time = 0, False, 0.0
        # cells cleared before the episode count as cleared at time 0
        self.clear_times = [0.0] * context.layout.cleared_cells
        config = context.env_config
        lidar = LidarConfig(
            config.get("n_rays", 64), config.get("lidar_range", 3.5), config.get("field_of_view", 2 * math.pi)
        )
        self.ray_angles, self.lidar_range = lidar.ray_angles(), lidar.max_range

    def plan(self, context: EpisodeContext, info: dict) -> list[Leg]:
        """This robot's legs in driving order (a subclass may take them from elsewhere, e.g. a file)."""
        # from where the robots are: a suite episode starts them anywhere in the start cell
        return plan_layout(
            context.layout,
            context.protocol,
            context.agent,
            context.n_agents,
            info["pose"][:2],
            context.team_start,
        )

    def act(self, observation: np.ndarray, info: dict) -> np.ndarray:
        cleared = info.get("cells_cleared", 0) + self.context.layout.cleared_cells
        while len(self.clear_times) < cleared:  # when each cell cleared: the departure gates count from it
            self.clear_times.append(info.get("time", 0.0))
        while self.leg < len(self.legs):
            leg = self.legs[self.leg]
            if not self.leg_started:
                if not self._may_start(leg, info):
                    return np.zeros(2)  # waiting for the cell to clear or for its turn
                self.follower.set_path(leg.waypoints)
                if len(leg.waypoints) > 1 and np.hypot(*(leg.waypoints[0] - info["pose"][:2])) < ON_WAYPOINT:
                    self.follower.skip_to(1)  # already there: turning to face it would waste a spin
                self.leg_started = True
            if not self.follower.done:
                break
            self.leg, self.leg_started = self.leg + 1, False
        if self.leg >= len(self.legs):
            return np.zeros(2)  # plan finished: wait for the team or the step limit
        action = self.follower.act(info["pose"])
        if self.context.n_agents > 1 and action[0] > 0 and self._robot_in_front(observation):
            self.blocked_time += TIME_STEP
            if self.blocked_time <= BLOCKED_PATIENCE:
                return np.array([0.0, action[1]])
        else:
            self.blocked_time = 0.0
        return action

    def _may_start(self, leg: Leg, info: dict) -> bool:
        if leg.after_cell is None:
            since = 0.0
        elif leg.after_cell < len(self.clear_times):
            since = self.clear_times[leg.after_cell]
        else:
            return False
        return info.get("time", 0.0) >= since + leg.delay - 1e-9

    def _robot_in_front(self, observation: np.ndarray) -> bool:
        """True when the lidar sees another robot in the strip the robot is about to drive into."""
        rays = lidar_rays(observation, self.context.observation_layout)
        robot_hits = rays[:, LIDAR_CHANNELS.index("robot")] > 0.5
        if not robot_hits.any():
            return False
        distance = rays[robot_hits, LIDAR_CHANNELS.index("distance")] * self.lidar_range
        angle = self.ray_angles[robot_hits]
        ahead, aside = distance * np.cos(angle), distance * np.sin(angle)
        radius = self.context.layout.robot.radius
        return bool(np.any((ahead > 0) & (ahead < radius + FOLLOW_GAP) & (np.abs(aside) < radius * 1.05)))
