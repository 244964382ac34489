"""Batched env for training: ``num_envs`` single-robot envs stepped in one call, torch tensors out.

:class:`BatchedCoverageEnv` keeps the exact semantics of :class:`~.coverage_env.CoverageEnv`
(same world, rewards, termination; env ``i`` is seeded ``seed + i``) and resets finished envs
itself, returning their first observation. :class:`RslRlVecEnv` adapts it to
``rsl_rl.env.VecEnv`` (rsl-rl-lib 5.5.1): observations as a ``TensorDict`` ``{"policy": [N, D]}``,
rewards ``[N]``, dones ``[N]``, ``extras["time_outs"]`` for truncations and ``extras["log"]``
with the metrics of the episodes that ended.
"""

from __future__ import annotations

import numpy as np
import torch
from rsl_rl.env import VecEnv
from tensordict import TensorDict

from .coverage_env import CoverageEnv, checked_action


class BatchedCoverageEnv:
    """Arguments as :class:`~.coverage_env.CoverageEnv` (minus rendering), plus ``num_envs`` and
    ``seed``; ``layout`` may also be a list, env ``i`` then running ``layout[i % len(layout)]``
    (e.g. the cleaning and the tracking cell in one batch). ``step`` returns (observations
    [N, D] float32, rewards [N], terminated [N] bool, truncated [N] bool, finished) where
    ``finished`` lists (env index, episode record) for every env whose episode ended on this step
    (those envs are already reset)."""

    def __init__(self, layout="a320_cell", num_envs: int = 64, seed: int = 0, **env_kwargs):
        layouts = layout if isinstance(layout, (list, tuple)) else [layout]
        self.envs = [CoverageEnv(layouts[index % len(layouts)], **env_kwargs) for index in range(num_envs)]
        self.num_envs = num_envs
        self.layout = self.envs[0].layout
        self.max_steps = max(env.max_steps for env in self.envs)
        self.observation_size = self.envs[0].observation_space.shape[0]
        self.seed = seed
        self.observations = np.zeros((num_envs, self.observation_size), dtype=np.float32)
        self.reset()

    def reset(self) -> torch.Tensor:
        for index, env in enumerate(self.envs):
            self.observations[index] = env.reset(seed=self.seed + index)[0]
        return torch.from_numpy(self.observations.copy())

    def step(self, actions: torch.Tensor):
        actions = checked_action(np.asarray(actions.detach().cpu() if isinstance(actions, torch.Tensor) else actions))
        if len(actions) != self.num_envs:
            raise ValueError(f"expected {self.num_envs} actions, got {len(actions)}")
        rewards = np.zeros(self.num_envs, dtype=np.float32)
        terminated = np.zeros(self.num_envs, dtype=bool)
        truncated = np.zeros(self.num_envs, dtype=bool)
        finished = []
        for index, (env, action) in enumerate(zip(self.envs, actions)):
            rewards[index], terminated[index], truncated[index] = env.advance(action[None])
            if terminated[index] or truncated[index]:
                finished.append((index, env.tracker.record()))
                self.observations[index] = env.reset()[0]
            else:
                self.observations[index] = env.world.observe(0)
        return (torch.from_numpy(self.observations.copy()), torch.from_numpy(rewards),
                torch.from_numpy(terminated), torch.from_numpy(truncated), finished)


class RslRlVecEnv(VecEnv):
    """``rsl_rl.env.VecEnv`` over a :class:`BatchedCoverageEnv` (CPU)."""

    LOGGED = ("coverage", "path_length", "collisions", "bound_violations", "cells_cleared", "success")

    def __init__(self, batched: BatchedCoverageEnv):
        self.env = batched
        self.num_envs = batched.num_envs
        self.num_actions = 2
        self.max_episode_length = torch.tensor([env.max_steps for env in batched.envs])
        self.episode_length_buf = torch.zeros(self.num_envs, dtype=torch.long)
        self.device = "cpu"
        self.cfg = {"layouts": sorted({env.layout.name for env in batched.envs}), "num_envs": batched.num_envs}
        self._observations = torch.from_numpy(batched.observations.copy())

    def get_observations(self) -> TensorDict:
        # a fresh tensor each call: PPO keeps a reference to the previous observation
        return TensorDict({"policy": self._observations.clone()}, batch_size=[self.num_envs])

    def step(self, actions: torch.Tensor):
        observations, rewards, terminated, truncated, finished = self.env.step(actions)
        self._observations = observations
        dones = terminated | truncated
        self.episode_length_buf += 1
        self.episode_length_buf[dones] = 0
        extras = {"time_outs": truncated.clone(), "log": {}}
        if finished:
            records = [record for _, record in finished]
            extras["log"] = {f"/episode/{name}": float(np.mean([r[name] for r in records])) for name in self.LOGGED}
        return TensorDict({"policy": observations}, batch_size=[self.num_envs]), rewards, dones.to(torch.long), extras
