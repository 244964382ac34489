"""A run's checkpoints and its folder: full rsl-rl checkpoints written atomically every ``save_interval``
iterations with the rest of the state a resumed run goes on from, the folder prepared (or checked for a
resume), and a lock that keeps a second process from training in it at the same time."""

from __future__ import annotations

import contextlib
import fcntl
import json
import os
import sys
from collections.abc import Iterator
from pathlib import Path

import torch
from cabinbench.baselines.ppo_gail.policy import atomic_torch_save
from cabinbench.baselines.ppo_gail.training.config import (
    CHECKPOINT_DIR,
    CONFIG_FILE,
    LOCK_FILE,
    RESUMABLE_CHANGES,
    TrainConfig,
)

from cabinbench.errors import UsageError


def checkpoint_path(run_dir: Path, iteration: int) -> Path:
    return run_dir / CHECKPOINT_DIR / f"model_{iteration:06d}.pt"


def latest_checkpoint(run_dir: str | os.PathLike) -> Path | None:
    """The checkpoint with the most iterations in ``run_dir/checkpoints``, or None."""
    folder = Path(run_dir) / CHECKPOINT_DIR
    found = sorted(folder.glob("model_*.pt")) if folder.is_dir() else []
    return found[-1] if found else None


def save_checkpoint(runner, run_dir: Path, iteration: int, config: TrainConfig, train_time: float) -> Path:
    """The algorithm's full state (rsl-rl's checkpoint dict plus the ICM and discriminator) after
    ``iteration`` completed iterations, and the rest of the run's state a resumed run goes on from
    (``rollout``: the envs' episodes in play, torch's random state, the logger's running sums)."""
    saved = runner.alg.save()
    saved["iter"] = iteration
    saved["infos"] = {"config": config.to_dict(), "train_time": train_time}
    saved["rollout"] = {
        "episodes": [(start, torch.from_numpy(actions)) for start, actions in runner.env.episodes()],
        "torch_random_state": torch.get_rng_state(),
        "episode_reward_sums": runner.logger.reward_sum.clone(),
        "episode_lengths": runner.logger.length.clone(),
    }
    path = checkpoint_path(run_dir, iteration)
    atomic_torch_save(saved, path)
    return path


def load_checkpoint(runner, path: Path) -> dict:
    """Restore the algorithm's full state from a checkpoint of ``save_checkpoint``; returns the checkpoint."""
    state = torch.load(path, weights_only=True, map_location="cpu")
    runner.alg.load(state, load_cfg=None, strict=True)
    return state


def resume_rollout(runner, state: dict, path: Path) -> None:
    """Put the run back where the checkpoint ``state`` (read from ``path``) left it: the envs into their
    episodes, torch's random state and the logger's sums. Call it last, after everything that draws
    random numbers while the runner is built."""
    rollout = state.get("rollout")
    if rollout is None:  # written before checkpoints kept it
        print(f"{path.name} keeps no episodes: the environments start new ones", file=sys.stderr)
        return
    runner.env.restore([(start, actions.numpy()) for start, actions in rollout["episodes"]])
    runner.logger.reward_sum.copy_(rollout["episode_reward_sums"])
    runner.logger.length.copy_(rollout["episode_lengths"])
    torch.set_rng_state(rollout["torch_random_state"])


def prepare_run_dir(config: TrainConfig, run_dir: Path, resume: bool) -> Path | None:
    """Create the run directory and its ``config.json``; return the checkpoint to resume from (or None)."""
    saved_config_path = run_dir / CONFIG_FILE
    checkpoint = latest_checkpoint(run_dir)
    if not resume:
        if checkpoint is not None:
            raise FileExistsError(
                f"{run_dir} already holds checkpoints (latest {checkpoint.name}); "
                "resume it (--resume) or choose another --run-dir"
            )
    else:
        check_resumable(config, run_dir)
    if resume and checkpoint is None:  # a sweep's run that never reached a checkpoint: from the start
        print(f"nothing to resume in {run_dir}: starting a new run", file=sys.stderr)
    (run_dir / CHECKPOINT_DIR).mkdir(parents=True, exist_ok=True)
    temporary = saved_config_path.with_suffix(".json.tmp")
    temporary.write_text(json.dumps(config.to_dict(), indent=2) + "\n")
    os.replace(temporary, saved_config_path)
    return checkpoint if resume else None


def check_resumable(config: TrainConfig, run_dir: Path) -> None:
    """Raise ValueError if the run in ``run_dir`` was started with a config that differs from ``config`` in
    more than ``RESUMABLE_CHANGES`` (a folder without ``config.json`` starts afresh)."""
    saved_config_path = run_dir / CONFIG_FILE
    if not saved_config_path.exists():
        return
    # through TrainConfig: a field added since the run started takes its default, as the resumed run does
    saved = json.loads(
        json.dumps(type(config).from_dict(json.loads(saved_config_path.read_text())).to_dict())
    )
    differences = sorted(
        key
        for key, value in config.to_dict().items()
        if key not in RESUMABLE_CHANGES and saved.get(key) != json.loads(json.dumps(value))
    )
    if differences:
        raise ValueError(
            f"cannot resume {run_dir}: the config differs from the saved one in {differences}; "
            f"only {list(RESUMABLE_CHANGES)} may change"
        )


@contextlib.contextmanager
def run_dir_lock(run_dir: Path) -> Iterator[None]:
    """Hold the lock of ``run_dir`` (its ``train.lock``, written with this process's pid) while training or
    exporting in it. A second process asking meanwhile gets a ``UsageError`` naming the holder, before it has
    changed anything in the folder: two processes writing one run's checkpoints would corrupt it. The lock
    goes with the process, however it ends."""
    run_dir.mkdir(parents=True, exist_ok=True)
    with open(run_dir / LOCK_FILE, "a+") as file:  # "a+": opening changes nothing another process holds
        try:
            fcntl.flock(file, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except BlockingIOError:
            file.seek(0)
            holder = file.read().strip() or "unknown"
            raise UsageError(
                f"{run_dir} is being trained by another process (pid {holder}); "
                "wait for it or give another --run-dir"
            ) from None
        file.seek(0)
        file.truncate()
        file.write(f"{os.getpid()}\n")
        file.flush()
        yield
