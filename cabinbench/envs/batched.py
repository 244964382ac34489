"""Batched env for training: ``num_envs`` single-robot envs stepped in one call, torch tensors out.

:class:`BatchedCoverageEnv` keeps the exact semantics of :class:`~.coverage_env.CoverageEnv`
(same world, rewards, termination; env ``i`` is seeded ``seed + i``) and resets finished envs
itself, returning their first observation. :class:`RslRlVecEnv` adapts it to
``rsl_rl.env.VecEnv`` (rsl-rl-lib 5.5.1): observations as a ``TensorDict`` ``{"policy": [N, D]}``,
rewards ``[N]``, dones ``[N]``, ``extras["time_outs"]`` for truncations and ``extras["log"]``
with the metrics of the episodes that ended.
"""

from __future__ import annotations

import array
import multiprocessing
import os
import time

import numpy as np
import torch
from gymnasium.utils import seeding
from rsl_rl.env import VecEnv
from tensordict import TensorDict

from cabinbench.envs.coverage_env import CoverageEnv, checked_action, checked_count
from cabinbench.envs.suite_env import SuiteEnv
from cabinbench.sim.physics import TIME_STEP

_CONTEXT = multiprocessing.get_context("spawn")  # no fork of torch's threads
SPIN_SECONDS = 0.002
"""How long a process polls a pipe before it blocks on it, where the main process and the workers
wait for each other at every step. On a virtual machine a CPU that blocks is halted and handed back
to the host, and waking it is slow: a message between the two processes of a step took a median
40-130 µs to be picked up when blocking, 25-35 µs polling (``a320_cell``, 64 envs, 2 workers, on
this project's 2-core VM). Waits longer than this (a training update between rollouts) still block.
Interleaved runs of ``bench_batched`` on the same machine, old (blocking) against new: 64 envs, 6
pairs, median 44k and 57k agent-steps/s; 256 envs, 12 pairs, 40k and 42k (within the noise)."""


class WorkerDied(RuntimeError):
    """A worker process of a :class:`BatchedCoverageEnv` ended while the batch waited for it."""


def _receive(connection):
    """``connection.recv()``, after polling for up to ``SPIN_SECONDS`` (yielding to any other
    runnable process)."""
    deadline = time.perf_counter() + SPIN_SECONDS
    while not connection.poll() and time.perf_counter() < deadline:
        os.sched_yield()
    return connection.recv()


class BatchArrays:
    """The batch's actions and step results, as numpy arrays over blocks of memory that, with
    ``shared``, the worker processes share (a worker unpickles the same memory, not a copy). Each
    shard reads its actions and writes its results in place, so a step sends a worker only a
    signal and gets back only the episodes that ended."""

    def __init__(
        self, num_envs: int, observation_size: int, shared: bool = False, blocks: dict | None = None
    ):
        self.num_envs, self.observation_size, self.shared = num_envs, observation_size, shared
        fields = {
            "actions": ((num_envs, 2), np.float64),
            "observations": ((num_envs, observation_size), np.float32),
            "rewards": ((num_envs,), np.float32),
            "terminated": ((num_envs,), np.bool_),
            "truncated": ((num_envs,), np.bool_),
        }
        if blocks is None:
            sizes = {
                name: int(np.prod(shape)) * np.dtype(dtype).itemsize
                for name, (shape, dtype) in fields.items()
            }
            blocks = {
                name: _CONTEXT.RawArray("b", size) if shared else bytearray(size)
                for name, size in sizes.items()
            }
        self.blocks = blocks
        for name, (shape, dtype) in fields.items():
            setattr(self, name, np.frombuffer(blocks[name], dtype).reshape(shape))

    def __reduce__(self):
        if not self.shared:
            raise TypeError("a worker given unshared batch arrays would write to a copy")
        return BatchArrays, (self.num_envs, self.observation_size, True, self.blocks)


class EpisodeLog:
    """How each env's episode in play began (its generator's state before the reset) and its actions
    since: enough to replay the envs into their episodes, so that a resumed training run goes on
    exactly as if it had never stopped. Env ``i`` starts as a reset with ``seeds[i]`` would."""

    def __init__(self, seeds: list[int]):
        self.starts = [seeding.np_random(seed)[0].bit_generator.state for seed in seeds]
        self.actions = [array.array("d") for _ in seeds]

    def acted(self, index: int, action: np.ndarray) -> None:
        """Env ``index`` took ``action`` (float64) and goes on with its episode."""
        self.actions[index].frombytes(action.tobytes())

    def resetting(self, index: int, env) -> None:
        """Env ``index`` is about to reset from its own generator."""
        self.starts[index], self.actions[index] = env.np_random.bit_generator.state, array.array("d")

    def episodes(self, action_shape: tuple[int, ...]) -> list[tuple[dict, np.ndarray]]:
        """(generator state, (steps, *action_shape) actions) of every env."""
        return [
            (start, np.frombuffer(actions).reshape(-1, *action_shape).copy())
            for start, actions in zip(self.starts, self.actions)
        ]

    def rewind(self, index: int, env, episode: tuple[dict, np.ndarray], action_shape: tuple[int, ...]):
        """Set env ``index``'s generator to ``episode``'s start, for the caller to reset the env and take
        (and log, with :meth:`acted`) the actions returned: float64, each of ``action_shape``."""
        start, actions = episode
        env.np_random.bit_generator.state = start
        self.starts[index], self.actions[index] = start, array.array("d")
        return np.asarray(actions, dtype=np.float64).reshape(-1, *action_shape)

    @staticmethod
    def replay_ended(env_name: str) -> ValueError:
        """The error of a saved episode that ends before its actions: other env code saved it."""
        return ValueError(
            f"{env_name}: its saved episode ended before its saved actions did, so the checkpoint was "
            "written by another version of the envs; start a new run, or export this one with --export-latest"
        )


class EnvShard:
    """A run of consecutive envs (global indices ``first`` ...) stepped in a loop, on their rows
    of ``batch``: ``CoverageEnv``s on ``layouts`` round-robin, or with ``suite`` ``SuiteEnv``s,
    each drawing a new layout of the suite at every reset from its seeded generator.

    An :class:`EpisodeLog` keeps each env's episode in play, for :meth:`episodes` and :meth:`restore`."""

    def __init__(
        self,
        layouts: list,
        first: int,
        count: int,
        seed: int,
        env_kwargs: dict,
        batch: BatchArrays,
        suite: str | None = None,
    ):
        self.first = first
        rows = slice(first, first + count)
        self.actions = batch.actions[rows, None]  # (count, 1, 2): each env's (K, 2) actions, K = 1
        self.observations, self.rewards = batch.observations[rows], batch.rewards[rows]
        self.terminated, self.truncated = batch.terminated[rows], batch.truncated[rows]
        self.envs = [
            SuiteEnv(suite, **env_kwargs)
            if suite
            else CoverageEnv(layouts[(first + k) % len(layouts)], **env_kwargs)
            for k in range(count)
        ]
        self.log = EpisodeLog([seed + first + k for k in range(count)])
        for k, env in enumerate(self.envs):
            self.observations[k] = env.reset(seed=seed + first + k)[0]

    def step(self) -> list[tuple[int, dict]]:
        """Step every env on its action; returns (env index, episode record) of the episodes that
        ended (those envs are reset: their row holds the new first observation)."""
        outcomes, finished = [], []
        for k, (env, action, observation) in enumerate(zip(self.envs, self.actions, self.observations)):
            step_reward, terminated, truncated = env.advance(action)
            outcomes.append((step_reward, terminated, truncated))
            if terminated or truncated:
                finished.append((self.first + k, env.tracker.record()))
                self.log.resetting(k, env)
                observation[:] = env.reset()[0]
            else:
                self.log.acted(k, action)
                env.world.observe(0, out=observation)
        self.rewards[:], self.terminated[:], self.truncated[:] = zip(*outcomes)
        return finished

    def episodes(self) -> list[tuple[dict, np.ndarray]]:
        """Each env's episode in play (:class:`EpisodeLog`): (generator state, (steps, 2) actions)."""
        return self.log.episodes((2,))

    def restore(self, episodes: list[tuple[dict, np.ndarray]]) -> None:
        """Replay ``episodes`` (as :meth:`episodes` returns them) into the envs, observations included."""
        for k, (env, episode) in enumerate(zip(self.envs, episodes, strict=True)):
            actions = self.log.rewind(k, env, episode, (1, 2))
            self.observations[k] = env.reset()[0]
            for action in actions:
                _, terminated, truncated = env.advance(action)
                if terminated or truncated:
                    raise EpisodeLog.replay_ended(f"env {self.first + k}")
                self.log.acted(k, action)
                env.world.observe(0, out=self.observations[k])


def _serve_shard(connection, *shard_arguments) -> None:
    """Worker process: build a shard, then run each (method name, arguments) it is sent on it and
    send back the result, until told to stop (None)."""
    shard = EnvShard(*shard_arguments)
    connection.send(None)  # its first observations are written
    try:
        while (command := _receive(connection)) is not None:
            name, arguments = command
            connection.send(getattr(shard, name)(*arguments))
    except EOFError:
        pass  # the main process ended without closing the env: nothing is left to step for
    connection.close()


class BatchedCoverageEnv:
    """Arguments as :class:`~.coverage_env.CoverageEnv` (minus rendering), plus ``num_envs``,
    ``seed`` and ``num_workers``; ``layout`` may also be a list, env ``i`` then running
    ``layout[i % len(layout)]`` (e.g. the cleaning and the tracking cell in one batch). With
    ``suite`` (a suite name) every env is a :class:`~.suite_env.SuiteEnv` instead (``layout`` is
    ignored): each reset draws a layout of the suite, as ``CabinBench/Suite-v0`` does, and the step
    limit is each drawn layout's own.
    ``step`` returns (observations [N, D] float32, rewards [N], terminated [N] bool, truncated
    [N] bool, finished) where ``finished`` lists (env index, episode record) for every env whose
    episode ended on this step (those envs are already reset).

    With ``num_workers > 1`` the envs are split into that many shards, stepped at the same time:
    the first in this process, each other one in a worker process of its own (the env step is
    single-threaded Python, so this is how a batch uses several cores).
    Env ``i`` is seeded ``seed + i`` however the batch is split: results do not depend on it.
    The workers are spawned and re-import the main script: create the env under ``if __name__ ==
    "__main__":``. A worker that dies raises :class:`WorkerDied` in the next call that waits for it.
    Call :meth:`close` (or use ``with``) to stop the workers.

    ``observation_layout`` maps each part of an observation row to its slice, as the single env's
    (:mod:`cabinbench.sim.observation`)."""

    def __init__(
        self,
        layout="a320_cell",
        num_envs: int = 64,
        seed: int = 0,
        num_workers: int = 1,
        suite: str | None = None,
        **env_kwargs,
    ):
        checked_count(num_envs, "num_envs")
        checked_count(num_workers, "num_workers")
        if suite:
            examples = [SuiteEnv(suite, **env_kwargs)]  # spaces and settings, for callers
            self.layout_names = [suite]
            # the longest step limit an env may draw: from the manifest, without generating the suite
            longest = max(entry["max_steps"] for entry in examples[0].suite.manifest().values())
            self.max_steps_per_env = [env_kwargs.get("max_steps") or longest] * num_envs
        else:
            requested = list(layout) if isinstance(layout, (list, tuple)) else [layout]
            examples = [CoverageEnv(name, **env_kwargs) for name in requested]
            self.layout_names = sorted({example.layout.name for example in examples})
            self.max_steps_per_env = [examples[index % len(examples)].max_steps for index in range(num_envs)]
        self.example_env = examples[0]
        self.num_envs = num_envs
        self.layout = self.example_env.layout
        self.observation_size = self.example_env.observation_space.shape[0]
        self.observation_layout = self.example_env.observation_layout  # part name -> slice of a row
        layouts = [
            example.layout for example in examples
        ]  # parsed once, shared by the envs (which only read them)
        bounds = np.linspace(0, num_envs, max(1, min(num_workers, num_envs)) + 1).astype(int)
        self.batch = BatchArrays(num_envs, self.observation_size, shared=len(bounds) > 2)
        self.shard_bounds = [(int(first), int(last)) for first, last in zip(bounds, bounds[1:])]
        self.observations = self.batch.observations
        shards = [
            (layouts, first, last - first, seed, env_kwargs, self.batch, suite)
            for first, last in self.shard_bounds
        ]
        self.workers = []
        for arguments in shards[1:]:
            parent, child = _CONTEXT.Pipe()
            process = _CONTEXT.Process(target=_serve_shard, args=(child, *arguments), daemon=True)
            process.start()
            child.close()  # the worker's end only: a worker that dies then ends the pipe (EOFError)
            self.workers.append((parent, process))
        try:
            self.local = EnvShard(*shards[0])  # built while the workers build theirs
            self._replies("starting")
        except BaseException:
            self._stop_workers()
            raise

    def step(self, actions: torch.Tensor):
        if isinstance(actions, torch.Tensor):
            actions = actions.detach().cpu()
        batch = self.batch
        batch.actions[:] = checked_action(actions, (self.num_envs, 2))
        finished = [
            item for shard_finished in self._on_every_shard("stepping", "step") for item in shard_finished
        ]
        # copies: callers keep the tensors of earlier steps
        return (
            torch.from_numpy(batch.observations.copy()),
            torch.from_numpy(batch.rewards.copy()),
            torch.from_numpy(batch.terminated.copy()),
            torch.from_numpy(batch.truncated.copy()),
            finished,
        )

    def episodes(self) -> list[tuple[dict, np.ndarray]]:
        """Every env's episode in play, in env order: (its generator's state before the reset, the
        (steps, 2) actions since). Plain numbers and arrays: a checkpoint can keep them."""
        return [
            episode for shard in self._on_every_shard("saving its episodes", "episodes") for episode in shard
        ]

    def restore(self, episodes: list[tuple[dict, np.ndarray]]) -> torch.Tensor:
        """Put every env back into its episode of ``episodes`` (from :meth:`episodes` of a batch with the
        same arguments, split over any number of workers): each is reset from its generator state and
        replays its actions, so that the batch goes on exactly as the saved one would have. Returns
        the observations."""
        if len(episodes) != self.num_envs:
            raise ValueError(f"{len(episodes)} episodes given for a batch of {self.num_envs} envs")
        arguments = [(episodes[first:last],) for first, last in self.shard_bounds]
        self._on_every_shard("restoring its episodes", "restore", arguments)
        return torch.from_numpy(self.batch.observations.copy())

    def _on_every_shard(self, doing: str, method: str, arguments: list[tuple] | None = None) -> list:
        """``EnvShard.method(*arguments[i])`` (default: no arguments) on every shard ``i`` at once, shard 0
        in this process; their results."""
        arguments = arguments or [()] * len(self.shard_bounds)
        for (parent, _), shard_arguments in zip(self.workers, arguments[1:]):
            try:  # the workers run theirs while this process runs the first shard's
                parent.send((method, shard_arguments))
            except BrokenPipeError:
                pass  # a dead worker: reported by _replies below
        try:
            local = getattr(self.local, method)(*arguments[0])
        finally:  # collect every reply, even if this shard failed, to keep the pipes in step
            replies = self._replies(doing)
        return [local, *replies]

    def _replies(self, doing: str) -> list:
        """Every worker's reply; a worker that died raises :class:`WorkerDied` (never a hang)."""
        replies = []
        for number, (parent, process) in enumerate(self.workers, start=1):
            try:
                replies.append(_receive(parent))
            except (EOFError, ConnectionError):
                process.join(timeout=5)
                self._stop_workers()
                raise WorkerDied(
                    f"worker {number} of the batched env died while {doing} (exit code {process.exitcode}; "
                    "its error, if any, is on stderr above). With num_workers > 1 the workers are spawned "
                    "and re-import your script: create the env under `if __name__ == '__main__':`"
                ) from None
        return replies

    def _stop_workers(self) -> None:
        for parent, process in self.workers:
            process.terminate()
            process.join(timeout=5)
            parent.close()
        self.workers = []

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
