"""The episodes imitation learns from, and how the boustrophedon expert labels them.

**The expert query.** The expert is the ``boustrophedon`` baseline itself, run in the shadow of each episode:
it plans once, from the episode's start pose (``Boustrophedon.reset``), and its ``act`` is called at every
visited state with that state's observation and ``info``, whoever drives. Its answer is its path follower's
command from the visited pose towards its plan, where its progress along the plan is that of the visited
trajectory (the follower moves on to the next waypoint when the robot, driven by anyone, reaches the end of
the segment it tracks). That is "what the expert would do here, having got here this way": from a pose off
its path it steers back onto the segment it is on (cross-track correction), it turns towards a waypoint it
has not reached, and it never re-plans. What it does not know: floor the learner cleaned off the plan (it
would sweep it again) and a robot far from its current segment (it drives back there rather than on).
Re-planning from every visited pose was the alternative; it would restart the whole sweep at each step, so
consecutive labels would contradict each other.

An episode ends where the env ends it, or where the expert has driven its whole plan: from then on it would
only stand still, which is no behaviour to imitate.

**The executed action.** With probability ``beta`` at each step the expert's action is executed, else the
learner's mean action (DAgger's mixture, Ross et al. 2011); ``beta`` = 1 (``bc``, and DAgger's round 0) is
the expert alone. The label recorded is the expert's either way.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import torch
from cabinbench.baselines.boustrophedon import Boustrophedon
from cabinbench.baselines.ppo_gail.networks import Actor

from cabinbench.agents import EpisodeContext


@dataclass(eq=False)
class EpisodeJob:
    """Episode ``episode`` of a round, to collect: on ``layout`` from ``seed``, in an env of ``env_kwargs``,
    the expert's action executed with probability ``beta``, else the ``learner``'s (a ``learner_snapshot``;
    None: the expert)."""

    episode: int
    layout: str
    seed: int
    env_kwargs: dict
    beta: float = 1.0
    learner: dict | None = None


@dataclass
class EpisodeData:
    """What an episode leaves: per step the ``observations`` [T, D], the expert's ``labels`` [T, 2], the
    ``executed`` actions [T, 2] and ``by_expert`` [T] (whose action was executed); the episode ``record``."""

    job: EpisodeJob
    observations: np.ndarray
    labels: np.ndarray
    executed: np.ndarray
    by_expert: np.ndarray
    record: dict


def learner_snapshot(actor: Actor) -> dict:
    """The weights of ``actor`` as plain tensors: what a worker process rebuilds it from."""
    return {
        "sizes": actor.sizes,
        "state_dict": {key: value.clone() for key, value in actor.state_dict().items()},
    }


def make_actor(observation_size: int, hidden_dims, activation: str, normalizer: dict) -> Actor:
    """ppo_gail's actor (``networks.Actor``: normaliser + MLP) for regression; ``sizes`` remembers its
    arguments."""
    actor = Actor(observation_size, 2, hidden_dims, activation, normalizer)
    actor.sizes = (observation_size, list(hidden_dims), activation, normalizer)
    return actor


def collect_episode(job: EpisodeJob) -> EpisodeData:
    """Play ``job``'s episode with the expert in its shadow (the module docstring)."""
    from cabinbench.episodes import make_env
    from cabinbench.layouts.resolve import load_layout

    torch.set_num_threads(1)
    env = make_env(load_layout(job.layout), "sequential", 1, job.env_kwargs)
    observation, info = env.reset(seed=job.seed)
    (agent,) = env.agents
    expert = Boustrophedon()
    context = EpisodeContext(
        env.unwrapped.layout,
        "sequential",
        job.seed,
        env_config=job.env_kwargs,
        observation_layout=env.unwrapped.observation_layout,
    )
    expert.reset(context, observation[agent], info[agent])
    learner = None
    if job.learner is not None:
        learner = make_actor(*job.learner["sizes"])
        learner.load_state_dict(job.learner["state_dict"])
        learner.eval()
    mixture = np.random.default_rng([job.seed, 1])
    rows = {"observations": [], "labels": [], "executed": [], "by_expert": []}
    while env.agents and expert.leg < len(expert.legs):  # a finished plan labels only standing still
        # float32, as recorded: a replay of the recorded actions is the episode
        label = np.clip(expert.act(observation[agent], info[agent]), -1.0, 1.0).astype(np.float32)
        from_expert = learner is None or mixture.random() < job.beta
        executed = label if from_expert else learner_action(learner, observation[agent]).astype(np.float32)
        for name, value in zip(rows, (observation[agent], label, executed, from_expert)):
            rows[name].append(value)
        observation, _, _, _, info = env.step({agent: executed})
    arrays = {name: np.array(values, dtype=np.float32) for name, values in rows.items()}
    arrays["by_expert"] = arrays["by_expert"].astype(bool)
    return EpisodeData(job, **arrays, record=env.episode_record)


def learner_action(actor: Actor, observation: np.ndarray) -> np.ndarray:
    """The actor's mean action for one observation, clipped to [-1, 1] as the env clips it."""
    with torch.no_grad():
        mean = actor(torch.as_tensor(observation, dtype=torch.float32).reshape(1, -1))[0]
    return np.clip(mean.numpy().astype(np.float64), -1.0, 1.0)
