"""Batched env for training: ``num_envs`` single-robot envs stepped in one call, torch tensors out.

:class:`BatchedCoverageEnv` keeps the exact semantics of :class:`~.coverage_env.CoverageEnv`
(same world, rewards, termination; env ``i`` is seeded ``seed + i``) and resets finished envs
itself, returning their first observation; it is the batch engine (:mod:`.batch_engine`) with one
robot per env. :class:`RslRlVecEnv` adapts it to ``rsl_rl.env.VecEnv`` (rsl-rl-lib 5.5.1):
observations as a ``TensorDict`` ``{"policy": [N, D]}``, rewards ``[N]``, dones ``[N]``,
``extras["time_outs"]`` for truncations and ``extras["log"]`` with the metrics of the episodes that
ended.
"""

from __future__ import annotations

import numpy as np
import torch
from rsl_rl.env import VecEnv
from tensordict import TensorDict

from cabinbench.envs.batch_engine import BatchedEnv, WorkerDied
from cabinbench.envs.settings import EnvSettings
from cabinbench.envs.suite_env import SUITE_SETTINGS
from cabinbench.sim.physics import TIME_STEP

__all__ = ["BatchedCoverageEnv", "RslRlVecEnv", "WorkerDied"]


class BatchedCoverageEnv(BatchedEnv):
    """Arguments as :class:`~.coverage_env.CoverageEnv` (the settings of
    :class:`~.settings.EnvSettings` but rendering), plus ``num_envs``, ``seed`` and ``num_workers``;
    ``layout`` may also be a list, env ``i`` then running ``layout[i % len(layout)]`` (e.g. the
    cleaning and the tracking cell in one batch). With ``suite`` (a suite name) every env draws a
    layout of the suite at each reset, as ``CabinBench/Suite-v0`` does (``layout`` is ignored), and
    the step limit is each drawn layout's own.
    ``step`` returns (observations [N, D] float32, rewards [N], terminated [N] bool, truncated
    [N] bool, finished) where ``finished`` lists (env index, episode record) for every env whose
    episode ended on this step (those envs are already reset). :meth:`episodes` gives each env's
    actions as (steps, 2).

    With ``num_workers > 1`` the envs are split over that many processes, with the same results
    (see :class:`~.batch_engine.BatchedEnv`: the workers re-import the main script, so create the
    env under ``if __name__ == "__main__":``; a worker that dies raises :class:`WorkerDied`; Ctrl-C
    stops the workers and raises ``KeyboardInterrupt``). Call :meth:`close` (or use ``with``).

    ``observation_layout`` maps each part of an observation row to its slice, as the single env's
    (:mod:`cabinbench.sim.observation`)."""

    def __init__(
        self,
        layout="a320_cell",
        num_envs: int = 64,
        seed: int = 0,
        num_workers: int = 1,
        suite: str | None = None,
        settings: EnvSettings | None = None,
        **overrides,
    ):
        settings = EnvSettings.of(settings or (SUITE_SETTINGS if suite else None), overrides)
        super().__init__(layout, num_envs, 1, seed, num_workers, suite, False, (2,), settings, False)


class RslRlVecEnv(VecEnv):
    """``rsl_rl.env.VecEnv`` over a :class:`BatchedCoverageEnv` (CPU).

    ``max_episode_length`` is the longest step limit of the batch's layouts (rsl-rl's
    ``learn(init_at_random_ep_len=True)`` draws ``episode_length_buf`` below it; episodes still end
    at each env's own limit, which does not read that buffer). ``step_dt`` is the simulated seconds
    per step and ``unwrapped`` the adapter itself (rsl-rl's RND scales its weight by them)."""

    LOGGED = ("coverage", "path_length", "collisions", "bound_violations", "cells_cleared", "success")

    def __init__(self, batched: BatchedCoverageEnv):
        self.env = batched
        self.num_envs = batched.num_envs
        self.num_actions = 2
        self.max_episode_length = max(batched.max_steps_per_env)
        self.step_dt = TIME_STEP
        self.episode_length_buf = torch.zeros(self.num_envs, dtype=torch.long)
        self.device = "cpu"
        self.cfg = {"layouts": batched.layout_names, "num_envs": batched.num_envs}
        self._observations = torch.from_numpy(batched.observations.copy())

    @property
    def unwrapped(self) -> RslRlVecEnv:
        return self

    def close(self) -> None:
        """Stop the batched env's workers."""
        self.env.close()

    def get_observations(self) -> TensorDict:
        # a fresh tensor each call: PPO keeps a reference to the previous observation
        return TensorDict({"policy": self._observations.clone()}, batch_size=[self.num_envs])

    def episodes(self) -> list[tuple[dict, np.ndarray]]:
        """The batched env's episodes in play (:meth:`BatchedCoverageEnv.episodes`)."""
        return self.env.episodes()

    def restore(self, episodes: list[tuple[dict, np.ndarray]]) -> None:
        """Go on from ``episodes`` (:meth:`BatchedCoverageEnv.restore`), episode lengths included."""
        self._observations = self.env.restore(episodes)
        rows_per_episode = self.num_envs // len(episodes)  # a team env's robots are rows of their own
        self.episode_length_buf = torch.tensor(
            [len(actions) for _, actions in episodes for _ in range(rows_per_episode)], dtype=torch.long
        )

    def step(self, actions: torch.Tensor):
        observations, rewards, terminated, truncated, finished = self.env.step(actions)
        self._observations = observations
        dones = terminated | truncated
        self.episode_length_buf += 1
        self.episode_length_buf[dones] = 0
        extras = {"time_outs": truncated.clone(), "log": {}}
        if finished:
            records = [record for _, record in finished]
            extras["log"] = {
                f"/episode/{name}": float(np.mean([r[name] for r in records])) for name in self.LOGGED
            }
        return (
            TensorDict({"policy": observations}, batch_size=[self.num_envs]),
            rewards,
            dones.to(torch.long),
            extras,
        )
