"""The episode loop and the job runner.

:func:`run_episode` plays one episode of a baseline on a layout. The baseline drives the robots
only through the env's actions (never by moving them): one instance per robot, each told its seat
in the team by :class:`~cabinbench.agents.EpisodeContext`. Any number of robots, one included, play
in the one env core, :class:`~cabinbench.envs.team_env.TeamCoverageEnv` (PettingZoo's parallel API;
the Gymnasium env is that env with one robot).

Seeding scheme: a run with base seed ``S`` plays episode ``i`` with seed ``S + i``: the env is
reset with it and every baseline instance gets it as ``context.seed``. An episode is therefore
reproduced on its own by ``--seed S+i --episodes 1``, and two runs whose seed ranges overlap
repeat the same episodes (the leaderboard shows episodes and distinct seeds side by side).

:func:`run_jobs` is the one seam between the benchmark and whatever executes episodes: an
executor of :mod:`cabinbench.executors` (a loop or a local process pool, or Ray tasks on a
cluster). Workers get the job, never a result of this process, so every executor gives the same
records.
"""

from __future__ import annotations

from collections.abc import Iterable, Iterator
from dataclasses import dataclass, field

import numpy as np

from cabinbench.agents import EpisodeContext, exact_action, load_baseline
from cabinbench.envs.team_env import TeamCoverageEnv
from cabinbench.executors.base import Executor, JobFailure
from cabinbench.executors.local import LocalExecutor
from cabinbench.layouts.model import Layout
from cabinbench.layouts.resolve import load_layout
from cabinbench.sim.render import draw_frame


@dataclass(frozen=True)
class EpisodeJob:
    """Everything a worker needs to play one episode (picklable: the layout travels by name/path)."""

    baseline: str  # registered name or package.module:Class
    layout: str  # registered name or YAML path
    seed: int  # the run's base seed
    episode: int  # index within the run; the episode's seed is seed + episode
    protocol: str = "sequential"
    n_agents: int = 1
    env_kwargs: dict = field(default_factory=dict)  # reward, max_steps, lidar settings ...
    baseline_config: dict = field(default_factory=dict)
    frame_every: int | None = None  # render a frame every this many steps (None: no frames)

    @property
    def episode_seed(self) -> int:
        return self.seed + self.episode


@dataclass
class EpisodeResult:
    job: EpisodeJob
    record: dict  # the env's episode_record: every metric of cabinbench.metrics
    trajectory: dict  # see run_episode


def make_env(layout: Layout, protocol: str, n_agents: int, env_kwargs: dict) -> TeamCoverageEnv:
    """The env for ``n_agents`` robots (one robot too) in PettingZoo's parallel API."""
    return TeamCoverageEnv(layout, n_agents, protocol=protocol, **env_kwargs)


def run_episode(
    baseline_spec: str,
    layout: str | Layout,
    seed: int,
    protocol: str = "sequential",
    n_agents: int = 1,
    env_kwargs: dict | None = None,
    config: dict | None = None,
    frame_every: int | None = None,
) -> tuple[dict, dict]:
    """Play one episode; return ``(record, trajectory)``.

    ``seed`` seeds the env reset and every baseline instance (``context.seed``). The env is made
    with ``env_kwargs`` over the baseline's ``env_options`` (a learned policy's observation
    settings). ``record`` is the env's ``episode_record`` and ``start``, the pose ``[x, y,
    heading]`` the robot started from (a team: one per robot). ``trajectory`` holds full-resolution
    arrays: ``positions`` (steps + 1, K, 2) robot centres from ``info["pose"]``, ``coverage``
    (steps + 1,) from ``info["coverage"]``, ``pass_count`` (the final coverage raster, passes
    per pixel) and, when ``frame_every`` is set, ``frames``: :func:`~cabinbench.sim.render.draw_frame`
    pictures at the start, every ``frame_every`` steps and at the end.
    """
    layout = layout if isinstance(layout, Layout) else load_layout(layout)
    baselines = [load_baseline(baseline_spec, **(config or {})) for _ in range(n_agents)]
    env_kwargs = {**baselines[0].env_options, **(env_kwargs or {})}
    env = make_env(layout, protocol, n_agents, env_kwargs)
    observations, infos = env.reset(seed=seed)
    agents = list(env.agents)
    starts = [[float(v) for v in infos[agent]["pose"]] for agent in agents]
    for index, (agent, baseline) in enumerate(zip(agents, baselines)):
        context = EpisodeContext(
            layout,
            protocol,
            seed,
            agent=index,
            n_agents=n_agents,
            env_config=env_kwargs,
            observation_layout=env.observation_layout,
            team_start=np.array(starts),
        )
        baseline.reset(context, observations[agent], infos[agent])

    world = env.world
    positions = [[infos[agent]["pose"][:2] for agent in agents]]
    coverage = [infos[agents[0]]["coverage"]]
    frames = [draw_frame(world)] if frame_every else None
    steps = 0
    while env.agents:
        # Robots of a team all leave ``env.agents`` together, on the last step. The exact actions, as
        # every record was played (agents.Baseline says why not act's float32).
        actions = {
            agent: exact_action(baseline, observations[agent], infos[agent])
            for agent, baseline in zip(agents, baselines)
        }
        observations, _, _, _, infos = env.step(actions)
        steps += 1
        positions.append([infos[agent]["pose"][:2] for agent in agents])
        coverage.append(infos[agents[0]]["coverage"])
        if frame_every and (steps % frame_every == 0 or not env.agents):
            frames.append(draw_frame(world, np.array(positions)))
    record = {**env.episode_record, "start": starts[0] if n_agents == 1 else starts}
    trajectory = {
        "positions": np.array(positions, dtype=np.float64),
        "coverage": np.array(coverage, dtype=np.float64),
        "pass_count": world.pass_count.copy(),
    }
    if frames is not None:
        trajectory["frames"] = frames
    env.close()
    return record, trajectory


def run_job(job: EpisodeJob) -> EpisodeResult:
    """Play one job (a module-level function so that worker processes can receive it)."""
    record, trajectory = run_episode(
        job.baseline,
        job.layout,
        job.episode_seed,
        job.protocol,
        job.n_agents,
        job.env_kwargs,
        job.baseline_config,
        job.frame_every,
    )
    return EpisodeResult(job, record, trajectory)


def run_jobs(
    jobs: Iterable[EpisodeJob], executor: Executor | None = None
) -> Iterator[EpisodeResult | JobFailure]:
    """Run independent episode jobs with ``executor`` (default: a loop in this process), yielding
    each result as soon as it is finished (in completion order; each carries its job), or a
    :class:`~cabinbench.executors.JobFailure` for a job whose worker died."""
    yield from (executor or LocalExecutor()).map(run_job, jobs)
