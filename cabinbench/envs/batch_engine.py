"""The engine of the batched training envs: many team envs (K >= 1 robots each) stepped in one
call, split over worker processes, one batch row per robot.

:class:`BatchedEnv` steps ``num_envs`` :class:`~cabinbench.envs.team_env.TeamCoverageEnv` cores
(or, with ``suite``, :class:`~cabinbench.envs.suite_env.TeamSuiteEnv` cores) through
:meth:`~cabinbench.envs.team_env.TeamCoverageEnv.advance`, with the exact semantics of a single env
(env ``i`` is seeded ``seed + i``; a finished env is reset from its own generator and its rows hold
the new episode's first observations). Robot ``k`` of env ``i`` is row ``i * K + k``.
:class:`~cabinbench.envs.batched.BatchedCoverageEnv` (one robot per env) and
:class:`~cabinbench.envs.batched_team.BatchedTeamEnv` (teams, with the centralised critic's state)
are this engine.

Workers ignore Ctrl-C (SIGINT): the terminal sends it to the whole process group, and the main
process alone decides. Interrupted while it starts them or waits for them, it stops the workers and
raises ``KeyboardInterrupt``; no worker prints a traceback.
"""

from __future__ import annotations

import array
import contextlib
import multiprocessing
import os
import signal
import threading
import time
from multiprocessing import resource_tracker

import numpy as np
import torch
from gymnasium.utils import seeding

from cabinbench.envs.settings import EnvSettings, checked_action, checked_count
from cabinbench.envs.suite_env import TeamSuiteEnv
from cabinbench.envs.team_env import TeamCoverageEnv

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
    """A worker process of a batched env ended while the batch waited for it."""


def _receive(connection):
    """``connection.recv()``, after polling for up to ``SPIN_SECONDS`` (yielding to any other
    runnable process)."""
    deadline = time.perf_counter() + SPIN_SECONDS
    while not connection.poll() and time.perf_counter() < deadline:
        os.sched_yield()
    return connection.recv()


class BatchArrays:
    """The batch's actions and step results, one row per robot, as numpy arrays over blocks of memory
    that, with ``shared``, the worker processes share (a worker unpickles the same memory, not a
    copy). Each shard reads its actions and writes its results in place, so a step sends a worker
    only a signal and gets back only the episodes that ended. ``states`` has ``state_size`` columns
    (0: no state)."""

    def __init__(
        self,
        rows: int,
        observation_size: int,
        state_size: int = 0,
        shared: bool = False,
        blocks: dict | None = None,
    ):
        self.rows, self.observation_size, self.state_size, self.shared = (
            rows,
            observation_size,
            state_size,
            shared,
        )
        fields = {
            "actions": ((rows, 2), np.float64),
            "observations": ((rows, observation_size), np.float32),
            "states": ((rows, state_size), np.float32),
            "rewards": ((rows,), np.float32),
            "terminated": ((rows,), np.bool_),
            "truncated": ((rows,), np.bool_),
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
        return BatchArrays, (self.rows, self.observation_size, self.state_size, True, self.blocks)


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

    def resetting(self, index: int, env: TeamCoverageEnv) -> None:
        """Env ``index`` is about to reset from its own generator."""
        self.starts[index], self.actions[index] = env.np_random.bit_generator.state, array.array("d")

    def episodes(self, action_shape: tuple[int, ...]) -> list[tuple[dict, np.ndarray]]:
        """(generator state, (steps, *action_shape) actions) of every env."""
        return [
            (start, np.frombuffer(actions).reshape(-1, *action_shape).copy())
            for start, actions in zip(self.starts, self.actions)
        ]

    def rewind(self, index: int, env: TeamCoverageEnv, episode: tuple[dict, np.ndarray]) -> np.ndarray:
        """Set env ``index``'s generator to ``episode``'s start, for the caller to reset the env and take
        (and log, with :meth:`acted`) the actions returned: float64, (steps, K, 2)."""
        start, actions = episode
        env.np_random.bit_generator.state = start
        self.starts[index], self.actions[index] = start, array.array("d")
        return np.asarray(actions, dtype=np.float64).reshape(-1, env.n_agents, 2)


class EnvShard:
    """A run of consecutive envs (global indices ``first`` ...) stepped in a loop, on their rows of
    ``batch``: team env cores of ``n_agents`` robots on ``layouts`` round-robin, or with ``suite``
    suite cores, each drawing a new layout of the suite at every reset from its seeded generator.
    With ``observe_ended`` an env is observed on the step that ends its episode too, before its reset,
    as a PettingZoo loop does (the team batch); else not (the single-robot batch: nobody reads it).
    Both keep each batch's trajectories as they were: with lidar noise an observation draws from the
    env's generator, which also draws the next episode's start.

    An :class:`EpisodeLog` keeps each env's episode in play, for :meth:`episodes` and :meth:`restore`."""

    def __init__(
        self,
        layouts: list,
        first: int,
        count: int,
        seed: int,
        n_agents: int,
        settings: EnvSettings,
        batch: BatchArrays,
        suite: str | None = None,
        observe_ended: bool = False,
    ):
        self.first, self.n_agents, self.observe_ended = first, n_agents, observe_ended
        rows = slice(first * n_agents, (first + count) * n_agents)
        per_env = (count, n_agents)  # views of the batch's rows, env by env
        self.actions = list(batch.actions[rows].reshape(*per_env, 2))  # each env's (K, 2) view, made once
        self.observations = batch.observations[rows].reshape(*per_env, batch.observation_size)
        self.states = batch.states[rows].reshape(*per_env, batch.state_size)  # the env's state, a one-hot
        self._observation_rows = [list(robots) for robots in self.observations]  # each row's view, made once
        self._with_state = batch.state_size > 0
        self.rewards = batch.rewards[rows]
        self.terminated, self.truncated = batch.terminated[rows], batch.truncated[rows]
        self.envs = [
            TeamSuiteEnv(suite, None, n_agents, settings)
            if suite
            else TeamCoverageEnv(layouts[(first + k) % len(layouts)], n_agents, settings)
            for k in range(count)
        ]
        self.log = EpisodeLog([seed + first + k for k in range(count)])
        for k, env in enumerate(self.envs):
            env.begin_episode(seed + first + k)
            self._observe(k, env)

    def _observe(self, k: int, env: TeamCoverageEnv) -> None:
        """Env ``k``'s rows: each robot's observation, and (with states) the env's state."""
        for robot, row in enumerate(self._observation_rows[k]):
            env.world.observe(robot, out=row)
        if self._with_state:
            self.states[k, :, : -self.n_agents] = env.state()

    def step(self) -> list[tuple[int, dict]]:
        """Step every env on its actions; returns (env index, episode record) of the episodes that
        ended (those envs are reset: their rows hold the new first observations)."""
        rewards, ended, cut, finished = [], [], [], []
        for k, (env, action) in enumerate(zip(self.envs, self.actions)):
            env_rewards, terminated, truncated = env.advance(action)
            rewards += env_rewards
            ended.append(terminated)
            cut.append(truncated)
            if terminated or truncated:
                if self.observe_ended:
                    self._observe(k, env)
                finished.append((self.first + k, env.episode_record))
                self.log.resetting(k, env)
                env.begin_episode()
            else:
                self.log.acted(k, action)
            self._observe(k, env)
        self.rewards[:] = rewards
        self.terminated[:] = np.repeat(ended, self.n_agents)  # all K robots of an env end together
        self.truncated[:] = np.repeat(cut, self.n_agents)
        return finished

    def episodes(self, action_shape: tuple[int, ...]) -> list[tuple[dict, np.ndarray]]:
        """Each env's episode in play (:class:`EpisodeLog`): (generator state, (steps, *action_shape)
        actions)."""
        return self.log.episodes(action_shape)

    def restore(self, episodes: list[tuple[dict, np.ndarray]]) -> None:
        """Replay ``episodes`` (as :meth:`episodes` returns them) into the envs, observations included."""
        for k, (env, episode) in enumerate(zip(self.envs, episodes, strict=True)):
            actions = self.log.rewind(k, env, episode)
            env.begin_episode()
            self._observe(k, env)
            for action in actions:  # observed at every step, as in play: lidar noise draws from the generator
                _, terminated, truncated = env.advance(action)
                if terminated or truncated:
                    raise ValueError(
                        f"env {self.first + k}: its saved episode ended before its saved actions did, so the "
                        "checkpoint was written by another version of the envs; start a new run, or export "
                        "this one with --export-latest"
                    )
                self.log.acted(k, action)
                self._observe(k, env)


def _serve_shard(connection, batch: BatchArrays) -> None:
    """Worker process: build a shard of ``batch`` from the arguments it is sent first, then run each
    (method name, arguments) it is sent on it and send back the result, until told to stop (None).
    It starts with SIGINT blocked (:func:`_sigint_held`)."""
    # the main process stops the workers on Ctrl-C; ignoring it discards one that waited, blocked
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    signal.pthread_sigmask(signal.SIG_UNBLOCK, {signal.SIGINT})
    try:
        shard = EnvShard(batch=batch, **connection.recv())
        connection.send(None)  # its first observations are written
        while (command := _receive(connection)) is not None:
            name, arguments = command
            connection.send(getattr(shard, name)(*arguments))
    except (EOFError, ConnectionError):
        pass  # the main process ended without closing the env: nothing is left to step for
    connection.close()


@contextlib.contextmanager
def _sigint_held():
    """Hold Ctrl-C (SIGINT) while workers are spawned, and deliver it once they are. It is blocked in
    this thread, so a spawned worker inherits it blocked through ``exec`` and cannot die of it, with a
    traceback, while it imports (:func:`_serve_shard` ignores it, which discards one that waited, then
    unblocks it). From the main thread, one that reaches this process meanwhile (another of its threads
    may take it) is noted instead of raised in the middle of a spawn, and handed to the handler it
    replaced at the end, so that the caller can stop the workers. (Ignoring SIGINT here instead lost a
    Ctrl-C in this window.) The resource tracker is started first, as starting it unblocks SIGINT."""
    main_thread = threading.current_thread() is threading.main_thread()
    handler = signal.getsignal(signal.SIGINT) if main_thread else None
    noted = []
    if callable(handler):  # else SIG_IGN, SIG_DFL, or a handler set outside Python: left as they are
        signal.signal(signal.SIGINT, lambda number, frame: noted.append(frame))
    try:
        resource_tracker.ensure_running()
        mask = signal.pthread_sigmask(signal.SIG_BLOCK, {signal.SIGINT})
        try:
            yield
        finally:
            signal.pthread_sigmask(signal.SIG_SETMASK, mask)  # a Ctrl-C that waited is noted here
    finally:
        if callable(handler):
            signal.signal(signal.SIGINT, handler)
            if noted:
                handler(signal.SIGINT, noted[0])


class BatchedEnv:
    """``num_envs`` envs of ``n_agents`` robots stepped in one call (see the module docstring); the
    batch has ``num_envs * n_agents`` rows. ``step`` returns (observations [rows, D] float32, rewards
    [rows], terminated [rows] bool, truncated [rows] bool, finished), ``finished`` listing (env index,
    episode record) for every env whose episode ended on this step (those envs are already reset).
    With ``with_state`` the rows also hold the env's ``state()`` and a one-hot of the row's robot
    (``states``, [rows, S + K]). ``episode_shape`` is the shape of one step's actions in
    :meth:`episodes`; ``observe_ended``: see :class:`EnvShard`.

    With ``num_workers > 1`` the envs are split into that many shards, stepped at the same time: the
    first in this process, each other one in a worker process of its own (the env step is
    single-threaded Python, so this is how a batch uses several cores). Env ``i`` is seeded ``seed +
    i`` however the batch is split: results do not depend on it. The workers are spawned and
    re-import the main script: create the env under ``if __name__ == "__main__":``. A worker that dies
    raises :class:`WorkerDied` in the next call that waits for it. Call :meth:`close` (or use
    ``with``) to stop the workers."""

    def __init__(
        self,
        layout,
        num_envs: int,
        n_agents: int,
        seed: int,
        num_workers: int,
        suite: str | None,
        with_state: bool,
        episode_shape: tuple[int, ...],
        settings: EnvSettings,
        observe_ended: bool,
    ):
        checked_count(num_envs, "num_envs")
        checked_count(num_workers, "num_workers")
        self._describe(layout, num_envs, n_agents, suite, settings)
        self.episode_shape = episode_shape
        state_size = self.example_env.state_space.shape[0] + n_agents if with_state else 0
        bounds = np.linspace(0, num_envs, max(1, min(num_workers, num_envs)) + 1).astype(int)
        self.batch = BatchArrays(self.num_envs, self.observation_size, state_size, shared=len(bounds) > 2)
        if with_state:  # each row's robot, for the critic (the shards write the env's state beside it)
            self.batch.states[:, -n_agents:] = np.tile(np.eye(n_agents), (num_envs, 1))
        self.observations, self.states = self.batch.observations, self.batch.states
        self.shard_bounds = [(int(first), int(last)) for first, last in zip(bounds, bounds[1:])]
        shards = [
            {
                "layouts": self.layouts,
                "first": first,
                "count": last - first,
                "seed": seed,
                "n_agents": n_agents,
                "settings": settings,
                "suite": suite,
                "observe_ended": observe_ended,
            }
            for first, last in self.shard_bounds
        ]
        self.workers = []
        try:
            self._start_workers(shards[1:])
            self.local = EnvShard(batch=self.batch, **shards[0])  # built while the workers build theirs
            self._replies("starting")
        except BaseException:
            self._stop_workers()
            raise

    def _start_workers(self, shards: list[dict]) -> None:
        """A worker process for each of ``shards`` (:class:`EnvShard`'s arguments but the batch), then
        sent its arguments. Only the batch goes into the spawn, which holds Ctrl-C (:func:`_sigint_held`):
        a spawn writes its pickle into the worker's pipe, which the worker reads as it imports, so
        layouts larger than a pipe holds kept the spawn going for seconds. A send is interruptible,
        and the workers, spawned at once, import at the same time."""
        if not shards:
            return  # no resource tracker either
        with _sigint_held():
            for _ in shards:
                parent, child = _CONTEXT.Pipe()
                process = _CONTEXT.Process(target=_serve_shard, args=(child, self.batch), daemon=True)
                process.start()
                child.close()  # the worker's end only: a worker that dies then ends the pipe (EOFError)
                self.workers.append((parent, process))
        for (parent, _), arguments in zip(self.workers, shards):
            try:
                parent.send(arguments)
            except BrokenPipeError:
                pass  # a dead worker: reported by _replies

    def _describe(self, layout, num_envs: int, n_agents: int, suite: str | None, settings: EnvSettings):
        """The batch's spaces and limits, from one example env per layout (the envs only read the
        layouts: they are parsed once here and shared)."""
        if suite:
            examples = [TeamSuiteEnv(suite, None, n_agents, settings)]
            self.layout_names = [suite]
            # the longest step limit an env may draw: from the manifest, without generating the suite
            longest = max(entry["max_steps"] for entry in examples[0].suite.manifest().values())
            limits = [settings.max_steps or longest] * num_envs
        else:
            requested = list(layout) if isinstance(layout, (list, tuple)) else [layout]
            examples = [TeamCoverageEnv(name, n_agents, settings) for name in requested]
            self.layout_names = sorted({example.layout.name for example in examples})
            limits = [examples[index % len(examples)].max_steps for index in range(num_envs)]
        self.layouts = [example.layout for example in examples]
        self.example_env = examples[0]
        self.n_agents, self.num_teams, self.num_envs = n_agents, num_envs, num_envs * n_agents
        self.max_steps_per_env = [limit for limit in limits for _ in range(n_agents)]  # per row
        self.layout = self.example_env.layout
        self.observation_size = self.example_env.world.observation_size
        self.observation_layout = self.example_env.observation_layout  # part name -> slice of a row
        self.observation_config = self.example_env.observation_config

    def step(self, actions: torch.Tensor):
        if isinstance(actions, torch.Tensor):
            actions = actions.detach().cpu()
        batch = self.batch
        batch.actions[:] = checked_action(actions, (self.num_envs, 2))
        finished = [item for shard in self._on_every_shard("stepping", "step") for item in shard]
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
        (steps, *episode_shape) actions since). Plain numbers and arrays: a checkpoint can keep them."""
        arguments = [(self.episode_shape,)] * len(self.shard_bounds)
        return [
            episode
            for shard in self._on_every_shard("saving its episodes", "episodes", arguments)
            for episode in shard
        ]

    def restore(self, episodes: list[tuple[dict, np.ndarray]]) -> torch.Tensor:
        """Put every env back into its episode of ``episodes`` (from :meth:`episodes` of a batch with the
        same arguments, split over any number of workers): each is reset from its generator state and
        replays its actions, so that the batch goes on exactly as the saved one would have. Returns
        the observations."""
        if len(episodes) != self.num_teams:
            raise ValueError(f"{len(episodes)} episodes given for a batch of {self.num_teams} envs")
        arguments = [(episodes[first:last],) for first, last in self.shard_bounds]
        self._on_every_shard("restoring its episodes", "restore", arguments)
        return torch.from_numpy(self.batch.observations.copy())

    def _on_every_shard(self, doing: str, method: str, arguments: list[tuple] | None = None) -> list:
        """``EnvShard.method(*arguments[i])`` (default: no arguments) on every shard ``i`` at once, shard 0
        in this process; their results. Interrupted (Ctrl-C), it stops the workers before raising:
        their replies would no longer match the requests."""
        arguments = arguments or [()] * len(self.shard_bounds)
        try:
            for (parent, _), shard_arguments in zip(self.workers, arguments[1:]):
                try:  # the workers run theirs while this process runs the first shard's
                    parent.send((method, shard_arguments))
                except BrokenPipeError:
                    pass  # a dead worker: reported by _replies below
            try:
                local = getattr(self.local, method)(*arguments[0])
            finally:  # collect every reply, even if this shard failed, to keep the pipes in step
                replies = self._replies(doing)
        except KeyboardInterrupt:
            self._stop_workers()
            raise
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
