"""The study's cell-by-cell protocol, end to end through physics: goals clear a cell, bounds block
and count, exits move the robot on and the bound closes behind it."""

import numpy as np

from cabinbench.envs.coverage_env import CoverageEnv
from cabinbench.sim.lidar import BOUND, EXIT, GOAL

from .driving import drive


def goal_tour(layout, cell):
    """Waypoints from the aisle into each goal of ``cell`` and back."""
    aisle_y = layout.start[1]
    waypoints = []
    for x, y in layout.cells[cell].goals:
        waypoints += [(x, aisle_y), (x, y), (x, aisle_y)]
    return waypoints


def test_reaching_every_goal_clears_the_cell_and_ends_the_episode():
    env = CoverageEnv("a320_cell")
    env.reset(seed=0)
    info, terminated = drive(env, goal_tour(env.layout, 0))
    assert terminated
    record = env.episode_record
    assert record["goals_reached"] and record["cells_cleared"] == 1 and record["bound_violations"] == 0


def test_bounds_block_the_aisle_and_count_violations():
    env = CoverageEnv("full_cabin")
    env.reset(seed=0)
    env.step([0.0, 0.0])
    for _ in range(120):  # drive down the aisle towards the closed bound of cell 0
        *_, info = env.step([1.0, 0.0])
    bound_x = env.layout.passages[0].bounds[0, 0]
    assert info["pose"][0] < bound_x - 0.17  # the bound is solid
    assert info["bound_violations"] == 1
    open_env = CoverageEnv("full_cabin", protocol="open")
    open_env.reset(seed=0)
    for _ in range(120):
        *_, info = open_env.step([1.0, 0.0])
    assert info["pose"][0] > bound_x + 1.0 and info["bound_violations"] == 0


def test_exit_moves_the_robot_on_and_the_bound_closes_behind():
    env = CoverageEnv("a320_tracking_cell")
    observation, _ = env.reset(seed=0)
    tags = observation[:-2].reshape(-1, 6)[:, 1:].argmax(axis=1) + 1
    assert EXIT in tags[observation[:-2].reshape(-1, 6)[:, 1:].sum(axis=1) > 0]  # the exit shows
    exit_point = env.layout.passages[0].exits[0]
    info, _ = drive(env, [(exit_point[0] - 0.3, exit_point[1]), tuple(exit_point)])
    assert info["current_cell"] == 1
    for _ in range(5):
        *_, info = env.step([0.3, 0.0])
    world = env.world
    assert world.segment_on[world.bound_slices[0]].all()  # closed behind the robot
    goals, exits = world.markers_visible()
    assert goals.sum() == 4 and not exits.any()
    # the next cell's goals are what the lidar tags now
    observation = world.observe(0)
    seen = observation[:-2].reshape(-1, 6)
    assert seen[:, GOAL].any() or seen[:, BOUND].any()


def test_open_protocol_succeeds_on_coverage():
    """In the open protocol an episode ends as a success once the layout's success coverage is reached,
    before the step limit, and not before it."""
    from cabinbench.episodes import run_episode

    layout = CoverageEnv("paper_matrix_a", protocol="open").layout
    record, trajectory = run_episode("boustrophedon", layout, 0, protocol="open")
    assert record["success"] and record["coverage"] >= layout.success_coverage
    assert record["steps"] < layout.max_steps
    assert trajectory["coverage"][-2] < layout.success_coverage  # the step before the last had not reached it


def test_every_bound_the_team_passed_closes_once_all_robots_are_through():
    """The leader clears two cells and passes two exits while the other robot waits in cell 0:
    both bounds stay open for it, and both close once it has caught up."""
    from cabinbench.layouts.resolve import load_layout
    from cabinbench.sim.world import World

    world = World(load_layout("full_cabin"), n_robots=2, protocol="sequential")
    world.reset(np.random.default_rng(0))
    idle = np.zeros((2, 2))

    def move(robot, point):  # teleport, then one idle step for the protocol to see it
        world.bodies[robot].position = (float(point[0]), float(point[1]))
        world.step(idle)

    def bound_closed(passage):
        return bool(world.segment_on[world.bound_slices[passage]].all())

    for cell in (0, 1):
        goals = np.flatnonzero(world.goal_cell == cell)
        world.goal_reached[goals[:-1]] = True  # the leader has been everywhere but the last goal
        move(0, world.layout.goals[goals[-1]])
        assert world.cell_cleared[cell] and not bound_closed(cell)
        move(0, world.layout.passages[cell].exits[0])
        assert world.current_cell == cell + 1
    assert not bound_closed(0) and not bound_closed(1)  # robot 1 is still in cell 0
    cell_2_goals = world.layout.goals[world.goal_cell == 2]
    world.bodies[0].position = tuple(map(float, cell_2_goals[0]))
    move(1, cell_2_goals[1])
    assert bound_closed(0) and bound_closed(1)


def test_random_start_draws_a_seeded_pose_where_the_robot_fits_in_the_start_cell():
    fixed = CoverageEnv("a320_tracking_cell")
    assert np.array_equal(fixed.reset(seed=5)[1]["pose"], fixed.layout.start)

    env, twin = (
        CoverageEnv("a320_tracking_cell", random_start=True),
        CoverageEnv("a320_tracking_cell", random_start=True),
    )
    layout = env.layout
    start_cell = layout.cell_raster[layout.to_pixel(*layout.start[:2])]
    poses = []
    for seed in range(20):
        pose = env.reset(seed=seed)[1]["pose"]
        np.testing.assert_array_equal(pose, twin.reset(seed=seed)[1]["pose"])
        pixel = layout.to_pixel(*pose[:2])
        assert layout.cell_raster[pixel] == start_cell and layout.centre_free[pixel]
        poses.append(pose)
    poses = np.array(poses)
    assert (
        len(np.unique(poses[:, :2], axis=0)) >= 15 and np.ptp(poses[:, 2]) > 3.0
    )  # spread over the cell and around

    # The same seed gives the same episode from there on.
    rng = np.random.default_rng(0)
    for action in rng.uniform(-1, 1, (300, 2)):
        first, second = env.step(action), twin.step(action)
        np.testing.assert_array_equal(first[0], second[0])
        assert first[1:4] == second[1:4]
