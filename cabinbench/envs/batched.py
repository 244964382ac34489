"""Batched env for training: ``num_envs`` single-robot envs stepped in one call, torch tensors out.

:class:`BatchedCoverageEnv` keeps the exact semantics of :class:`~.coverage_env.CoverageEnv`
(same world, rewards, termination; env ``i`` is seeded ``seed + i``) and resets finished envs
itself, returning their first observation. :class:`RslRlVecEnv` adapts it to
``rsl_rl.env.VecEnv`` (rsl-rl-lib 5.5.1): observations as a ``TensorDict`` ``{"policy": [N, D]}``,
rewards ``[N]``, dones ``[N]``, ``extras["time_outs"]`` for truncations and ``extras["log"]``
with the metrics of the episodes that ended.
"""

from __future__ import annotations

import multiprocessing

import numpy as np
import torch
from rsl_rl.env import VecEnv
from tensordict import TensorDict

from .coverage_env import CoverageEnv, checked_action


class EnvShard:
    """A run of consecutive envs (global indices ``first`` ...) stepped in a loop, numpy in and out."""

    def __init__(self, layouts: list, first: int, count: int, seed: int, env_kwargs: dict):
        self.first = first
        self.envs = [CoverageEnv(layouts[(first + k) % len(layouts)], **env_kwargs) for k in range(count)]
        self.observations = np.stack([env.reset(seed=seed + first + k)[0] for k, env in enumerate(self.envs)])

    def step(self, actions: np.ndarray):
        count = len(self.envs)
        rewards, terminated, truncated = np.zeros(count, np.float32), np.zeros(count, bool), np.zeros(count, bool)
        finished = []
        for k, (env, action) in enumerate(zip(self.envs, actions)):
            rewards[k], terminated[k], truncated[k] = env.advance(action[None])
            if terminated[k] or truncated[k]:
                finished.append((self.first + k, env.tracker.record()))
                self.observations[k] = env.reset()[0]
            else:
                self.observations[k] = env.world.observe(0)
        return self.observations, rewards, terminated, truncated, finished


def _serve_shard(connection, *shard_arguments) -> None:
    """Worker process: build a shard, then answer step requests until told to stop (None)."""
    shard = EnvShard(*shard_arguments)
    connection.send(shard.observations)
    while (actions := connection.recv()) is not None:
        connection.send(shard.step(actions))
    connection.close()


class BatchedCoverageEnv:
    """Arguments as :class:`~.coverage_env.CoverageEnv` (minus rendering), plus ``num_envs``,
    ``seed`` and ``num_workers``; ``layout`` may also be a list, env ``i`` then running
    ``layout[i % len(layout)]`` (e.g. the cleaning and the tracking cell in one batch).
    ``step`` returns (observations [N, D] float32, rewards [N], terminated [N] bool, truncated
    [N] bool, finished) where ``finished`` lists (env index, episode record) for every env whose
    episode ended on this step (those envs are already reset).

    With ``num_workers > 1`` the envs are split into that many shards, each stepped in its own
    process (the env step is single-threaded Python, so this is how a batch uses several cores).
    Env ``i`` is seeded ``seed + i`` however the batch is split: results do not depend on it.
    Call :meth:`close` (or use ``with``) to stop the workers."""

    def __init__(self, layout="a320_cell", num_envs: int = 64, seed: int = 0, num_workers: int = 1, **env_kwargs):
        layouts = list(layout) if isinstance(layout, (list, tuple)) else [layout]
        examples = [CoverageEnv(name, **env_kwargs) for name in layouts]  # spaces and settings, for callers
        self.example_env = examples[0]
        self.num_envs = num_envs
        self.layout = self.example_env.layout
        self.layout_names = sorted({example.layout.name for example in examples})
        self.max_steps_per_env = [examples[index % len(examples)].max_steps for index in range(num_envs)]
        self.observation_size = self.example_env.observation_space.shape[0]
        bounds = np.linspace(0, num_envs, max(1, min(num_workers, num_envs)) + 1).astype(int)
        shards = [(layouts, int(first), int(last - first), seed, env_kwargs) for first, last in zip(bounds, bounds[1:])]
        self.observations = np.zeros((num_envs, self.observation_size), dtype=np.float32)
        self.slices = [slice(first, first + count) for _, first, count, _, _ in shards]
        if len(shards) == 1:
            self.local, self.workers = EnvShard(*shards[0]), []
            self.observations[:] = self.local.observations
        else:
            context = multiprocessing.get_context("spawn")  # no fork of torch's threads
            self.local, self.workers = None, []
            for arguments in shards:
                parent, child = context.Pipe()
                process = context.Process(target=_serve_shard, args=(child, *arguments), daemon=True)
                process.start()
                self.workers.append((parent, process))
            for (parent, _), part in zip(self.workers, self.slices):
                self.observations[part] = parent.recv()

    def step(self, actions: torch.Tensor):
        actions = checked_action(np.asarray(actions.detach().cpu() if isinstance(actions, torch.Tensor) else actions))
        if len(actions) != self.num_envs:
            raise ValueError(f"expected {self.num_envs} actions, got {len(actions)}")
        if self.local is not None:
            parts = [self.local.step(actions)]
        else:
            for (parent, _), part in zip(self.workers, self.slices):
                parent.send(actions[part])
            parts = [parent.recv() for parent, _ in self.workers]
        self.observations[:] = np.concatenate([part[0] for part in parts])
        rewards, terminated, truncated = (np.concatenate([part[i] for part in parts]) for i in (1, 2, 3))
        finished = [item for part in parts for item in part[4]]
        return (torch.from_numpy(self.observations.copy()), torch.from_numpy(rewards),
                torch.from_numpy(terminated), torch.from_numpy(truncated), finished)

    def close(self) -> None:
        for parent, process in self.workers:
            parent.send(None)
            process.join(timeout=5)
        self.workers = []

    def __enter__(self):
        return self

    def __exit__(self, *exc_info):
        self.close()


class RslRlVecEnv(VecEnv):
    """``rsl_rl.env.VecEnv`` over a :class:`BatchedCoverageEnv` (CPU)."""

    LOGGED = ("coverage", "path_length", "collisions", "bound_violations", "cells_cleared", "success")

    def __init__(self, batched: BatchedCoverageEnv):
        self.env = batched
        self.num_envs = batched.num_envs
        self.num_actions = 2
        self.max_episode_length = torch.tensor(batched.max_steps_per_env)
        self.episode_length_buf = torch.zeros(self.num_envs, dtype=torch.long)
        self.device = "cpu"
        self.cfg = {"layouts": batched.layout_names, "num_envs": batched.num_envs}
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
