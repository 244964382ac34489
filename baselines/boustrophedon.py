"""``boustrophedon``: the classic coverage planner, planned from the layout and driven through the
env's actions (never by moving the robot).

Planning (:func:`plan_layout`) runs the raster pipeline of :mod:`.coverage_planning`
(boustrophedon decomposition → swaths → route → A* transits) on the reachable robot-centre
raster. In the ``sequential`` protocol it plans cell by cell, as the cells open: each cell's
sweep stays clear of its closed bounds and sweeps the sub-cells holding goal markers last (so
that the cell, which clears when its last goal is reached, is fully swept by then), then an A*
transit drives to the exit landmark of the next cell. In ``open`` the whole layout is one plan.
In a team, robot ``agent`` of ``n_agents`` takes its share (:func:`team_share`).

Following: a :class:`~.path_following.PathFollower` turns the waypoints into velocity commands
from ``info["pose"]``.

Demonstrations for GAIL: :func:`record_demonstrations` runs this baseline in the env and saves
``observations`` [N, D] float32, ``actions`` [N, 2] float32, ``episode`` [N] int32 and
``observation_config`` (JSON of the env settings that shape the observation) to an ``.npz``.
"""

from __future__ import annotations

import json
from dataclasses import dataclass

import numpy as np

from cabinbench.layout import RESOLUTION, Layout
from cabinbench.world import TIME_STEP, start_poses

from .base import Baseline, EpisodeContext
from .coverage_planning import FreeSpace, pixels_to_world, plan_coverage, world_to_pixel
from .path_following import PathFollower

BOUND_MARGIN = 0.03  # metres kept between the robot's disc and a closed bound


@dataclass
class Leg:
    """One stretch of the plan: ``waypoints`` (N, 2) metres; ``purpose`` is "sweep", "goals" or "exit"."""

    waypoints: np.ndarray
    cell: int
    purpose: str


def plan_layout(layout: Layout, protocol: str = "sequential", agent: int = 0, n_agents: int = 1) -> list[Leg]:
    """The whole plan for robot ``agent`` of a team of ``n_agents``, as legs in driving order."""
    start = start_poses(layout, n_agents)[agent, :2]
    drivable = layout.centre_free  # already keeps the disc 1 cm off every wall
    if protocol == "open":
        region = team_share(layout, drivable, agent, n_agents)
        return [Leg(_plan(layout, region, start, goals=None).waypoints, 0, "sweep")]
    legs, position = [], start
    first_cell = max(0, layout.cleared_cells - 1)
    for cell in range(first_cell, len(layout.cells)):
        if cell >= layout.cleared_cells:
            region = team_share(layout, drivable & _cell_region(layout, cell), agent, n_agents)
            goals = layout.cells[cell].goals
            plan = _plan(layout, region, position, goals)
            if cell + 1 == len(layout.cells) and len(goals):
                # Reaching the last goal ends the episode: hold back the goal this sweep would
                # touch last, sweep around its spot, then drive to it.
                final_goal = goals[np.argmax(_first_touches(plan.waypoints, goals, layout.robot.radius))]
                keep_off = _near_points(layout, final_goal[None], layout.robot.radius + 0.02)
                plan = _plan(layout, region & ~keep_off, position, goals)
                legs.append(Leg(plan.waypoints, cell, "sweep"))
                legs.append(Leg(_transit(layout, region | keep_off, plan.waypoints[-1], final_goal), cell, "goals"))
            else:
                legs.append(Leg(plan.waypoints, cell, "sweep"))
            position = legs[-1].waypoints[-1]
        if cell + 1 < len(layout.cells):
            exits = layout.passages[cell].exits
            exit_point = exits[np.argmin(np.hypot(*(exits - position).T))]
            corridor = drivable & np.isin(layout.cell_raster, (cell, cell + 1)) & ~_near_bounds(layout, cell - 1)
            legs.append(Leg(_transit(layout, corridor, position, exit_point), cell, "exit"))
            position = exit_point
    return legs


def _plan(layout: Layout, region: np.ndarray, start: np.ndarray, goals: np.ndarray | None):
    robot = layout.robot
    goal_pixels = [] if goals is None else [world_to_pixel(g, RESOLUTION, layout.origin) for g in goals]
    last_cells = (lambda cell: any(cell.contains(*pixel) for pixel in goal_pixels)) if goal_pixels else None
    return plan_coverage(region, RESOLUTION, layout.origin, robot.tool_width, start, last_cells,
                         max_speed=robot.max_speed, max_turn_rate=robot.max_turn_rate)


def _near_points(layout: Layout, points: np.ndarray, distance: float) -> np.ndarray:
    xs, ys = layout.pixel_centres()
    grid_x, grid_y = np.meshgrid(xs, ys)
    near = np.zeros(layout.raster_shape, dtype=bool)
    for x, y in points:
        near |= np.hypot(grid_x - x, grid_y - y) < distance
    return near


def _transit(layout: Layout, region: np.ndarray, start: np.ndarray, end: np.ndarray) -> np.ndarray:
    """An A* path (metres) from ``start`` to ``end`` through ``region``."""
    pixels = FreeSpace(region).transit(world_to_pixel(start, RESOLUTION, layout.origin), world_to_pixel(end, RESOLUTION, layout.origin))
    return np.vstack([start, pixels_to_world(pixels, RESOLUTION, layout.origin)[1:-1], end])


def _first_touches(waypoints: np.ndarray, points: np.ndarray, reach: float) -> np.ndarray:
    """For each point, how far along the path (metres) the robot centre first comes within ``reach``."""
    steps = [np.linspace(a, b, max(2, int(np.hypot(*(b - a)) / 0.02) + 1)) for a, b in zip(waypoints[:-1], waypoints[1:])]
    dense = np.vstack(steps) if steps else waypoints
    travelled = np.concatenate([[0.0], np.cumsum(np.hypot(*np.diff(dense, axis=0).T))])
    within = np.hypot(dense[:, None, 0] - points[None, :, 0], dense[:, None, 1] - points[None, :, 1]) <= reach
    return np.where(within.any(axis=0), travelled[within.argmax(axis=0)], travelled[-1])


def _near_bounds(layout: Layout, passage: int) -> np.ndarray:
    """Pixels where the robot's disc would touch the bounds of ``passage`` (none if out of range)."""
    near = np.zeros(layout.raster_shape, dtype=bool)
    if not 0 <= passage < len(layout.passages):
        return near
    xs, ys = layout.pixel_centres()
    grid_x, grid_y = np.meshgrid(xs, ys)
    for x0, y0, x1, y1 in layout.passages[passage].bounds:
        direction = np.array([x1 - x0, y1 - y0])
        t = np.clip(((grid_x - x0) * direction[0] + (grid_y - y0) * direction[1]) / direction.dot(direction), 0, 1)
        near |= np.hypot(grid_x - (x0 + t * direction[0]), grid_y - (y0 + t * direction[1])) < layout.robot.radius + BOUND_MARGIN
    return near


def _cell_region(layout: Layout, cell: int) -> np.ndarray:
    """Robot-centre pixels of ``cell`` that keep the disc off the bounds on either side."""
    return layout.centre_free & (layout.cell_raster == cell) & ~_near_bounds(layout, cell - 1) & ~_near_bounds(layout, cell)


def team_share(layout: Layout, region: np.ndarray, agent: int, n_agents: int) -> np.ndarray:
    """Robot ``agent``'s part of ``region``: the region cut across the cabin's length into
    ``n_agents`` strips of equal coverable area (robot 0 nearest the start). Strips follow the
    cabin's long axis so that each robot keeps whole legroom pockets."""
    if n_agents == 1:
        return region
    columns = np.flatnonzero(region.any(axis=0))
    weights = region[:, columns].sum(axis=0).cumsum()
    edges = np.searchsorted(weights, weights[-1] * np.arange(1, n_agents) / n_agents)
    bounds = np.concatenate([[columns[0]], columns[np.minimum(edges, len(columns) - 1)], [columns[-1] + 1]])
    share = np.zeros_like(region)
    share[:, bounds[agent]: bounds[agent + 1]] = region[:, bounds[agent]: bounds[agent + 1]]
    return share


class Boustrophedon(Baseline):
    name = "boustrophedon"

    def reset(self, context: EpisodeContext, observation: np.ndarray, info: dict) -> None:
        super().reset(context, observation, info)
        self.legs = plan_layout(context.layout, context.protocol, context.agent, context.n_agents)
        robot = context.layout.robot
        self.follower = PathFollower(self.legs[0].waypoints, robot.max_speed, robot.max_turn_rate, TIME_STEP)
        self.leg = 0

    def act(self, observation: np.ndarray, info: dict) -> np.ndarray:
        while self.follower.done and self.leg + 1 < len(self.legs):
            self.leg += 1
            self.follower.set_path(self.legs[self.leg].waypoints)
        if self.follower.done:
            return np.zeros(2)  # plan finished: wait for the team or the step limit
        return self.follower.act(info["pose"])


def record_demonstrations(layout: str, episodes: int, path: str, seed: int = 0, **env_kwargs) -> dict:
    """Run the planner for ``episodes`` episodes and save (observation, action) pairs to ``path``.
    Returns a summary (steps, mean coverage, success rate)."""
    from cabinbench.envs.coverage_env import CoverageEnv

    env = CoverageEnv(layout, **env_kwargs)
    observations, actions, episode_of, records = [], [], [], []
    for episode in range(episodes):
        observation, info = env.reset(seed=seed + episode)
        planner = Boustrophedon()
        planner.reset(EpisodeContext(env.layout, env.world.protocol, seed + episode), observation, info)
        done = False
        while not done:
            action = np.clip(planner.act(observation, info), -1, 1)
            observations.append(observation)
            actions.append(action)
            episode_of.append(episode)
            observation, _, terminated, truncated, info = env.step(action)
            done = terminated or truncated
        records.append(info["episode_record"])
    config = observation_config(env)
    np.savez_compressed(path, observations=np.array(observations, dtype=np.float32),
                        actions=np.array(actions, dtype=np.float32), episode=np.array(episode_of, dtype=np.int32),
                        observation_config=np.array(json.dumps(config)))
    return {"steps": len(actions), "coverage": float(np.mean([r["coverage"] for r in records])),
            "success": float(np.mean([r["success"] for r in records]))}


def observation_config(env) -> dict:
    """The env settings that shape the observation: demonstrations must match the learner's."""
    lidar = env.world.lidar
    return {"n_rays": lidar.n_rays, "max_range": lidar.max_range, "field_of_view": lidar.field_of_view,
            "size": env.world.observation_size}
