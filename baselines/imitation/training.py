"""Training ``bc`` and ``dagger``: ``train(config, run_dir)`` runs ``config.iterations`` rounds, each

1. collecting ``episodes_per_iteration`` episodes from seeded random starts (``expert.collect_episode``; bc:
   the expert drives; dagger: the previous round's policy mixed with the expert), saved as
   ``data/round_<i>.npz``;
2. refitting the actor on the data of every round so far (mean squared error to the expert's labels; the
   weights go on from the last round; the observation normaliser is fixed from round 0's expert data);
3. writing ``checkpoints/model_<i>.pt`` (actor, optimiser, training time) and a row of ``metrics.csv``;
4. playing one episode with that checkpoint's policy (``validation/policy_<i>.pt``, mean actions) on each of
   ``validation_episodes`` layouts of ``cabin-v1-val`` from a random start: rows of ``validation.csv``
   with the headline ``clean_score``, whose ``layout`` column names the cabin-v1-val layout. No other
   layout is ever read to choose.

At the end ``policy.pt`` holds the checkpoint with the best ``clean_score`` on cabin-v1-val
(``training_records.validation_score``), or with ``export="last"`` the last one. ``resume`` goes on from
the latest checkpoint: rounds are seeded by (seed, round), so a resumed run collects and fits what the run
would have. It first validates every checkpoint whose rows are missing or lack ``clean_score`` (written
before bc and dagger recorded it), so a resumed finished run chooses again on the headline score.
"""

from __future__ import annotations

import csv
import os
import time
from pathlib import Path

import numpy as np
import torch
from cabinbench.baselines.imitation.config import TRAINING_SEED, ImitationConfig
from cabinbench.baselines.imitation.expert import EpisodeJob, collect_episode, learner_snapshot, make_actor
from cabinbench.baselines.ppo_gail.policy import atomic_torch_save, write_policy_file
from cabinbench.baselines.ppo_gail.training.checkpoints import (
    checkpoint_path,
    latest_checkpoint,
    prepare_run_dir,
    run_dir_lock,
)
from cabinbench.baselines.ppo_gail.training.config import (
    CURVES_FILE,
    METRICS_FILE,
    POLICY_FILE,
    VALIDATION_DIR,
    VALIDATION_FILE,
)
from cabinbench.baselines.ppo_gail.training.loop import TrainResult
from cabinbench.baselines.ppo_gail.training.validation import (
    SCORED_COLUMNS,
    Player,
    one_episode_each,
    validation_rows,
)

from cabinbench.envs.settings import observation_config
from cabinbench.executors.local import LocalExecutor
from cabinbench.training_records import best_checkpoint, read_metrics, validation_score

DATA_DIR = "data"
METRICS_COLUMNS = (
    "iteration", "episodes", "steps", "expert_share", "fit_loss_first", "fit_loss",
    "coverage", "success", "timesteps", "train_time",
)  # fmt: skip
"""``metrics.csv``: per round its episodes' steps and the share of them the expert drove, the regression loss
of the refit's first and last epoch, the episodes' mean coverage and success, and the steps so far (the
data the refit used) and seconds of training so far."""
NORMALIZER_EPS = 1.0e-2  # rsl-rl's EmpiricalNormalization's: a one-hot tag never seen stays near 0


class Learner:
    """The actor being fitted, its optimiser and normaliser; ``fit`` refits it on (observation, label)."""

    def __init__(self, config: ImitationConfig, observations: np.ndarray) -> None:
        data = observations.astype(np.float64)
        normalizer = {
            "mean": torch.as_tensor(data.mean(axis=0), dtype=torch.float32),
            "std": torch.as_tensor(data.std(axis=0), dtype=torch.float32),
            "eps": NORMALIZER_EPS,
        }
        torch.manual_seed(config.seed)  # the actor's initial weights
        self.actor = make_actor(observations.shape[1], config.hidden_dims, config.activation, normalizer)
        self.optimizer = torch.optim.Adam(self.actor.mlp.parameters(), lr=config.learning_rate)
        self.action_std = torch.ones(2)

    def fit(self, config: ImitationConfig, iteration: int, observations, labels) -> tuple[float, float]:
        """``config.epochs`` epochs of mini-batch MSE on all the data; (first, last) epoch's mean loss. The
        residual std of each action becomes the policy's ``action_std``."""
        generator = torch.Generator().manual_seed(config.seed * 100_003 + iteration)
        observations = torch.as_tensor(observations)
        labels = torch.as_tensor(labels)
        losses = []
        self.actor.train()
        for _ in range(config.epochs):
            order = torch.randperm(len(labels), generator=generator)
            total = 0.0
            for batch in order.split(config.batch_size):
                loss = torch.nn.functional.mse_loss(self.actor(observations[batch].float()), labels[batch])
                self.optimizer.zero_grad()
                loss.backward()
                self.optimizer.step()
                total += loss.item() * len(batch)
            losses.append(total / len(labels))
        self.actor.eval()
        with torch.no_grad():
            residual = self.actor(observations.float()) - labels
        self.action_std = residual.pow(2).mean(dim=0).sqrt().clamp_min(1.0e-3)
        return losses[0], losses[-1]

    def state(self) -> dict:
        return {
            "actor": self.actor.state_dict(),
            "optimizer": self.optimizer.state_dict(),
            "action_std": self.action_std,
        }

    def load(self, state: dict) -> None:
        self.actor.load_state_dict(state["actor"])
        self.optimizer.load_state_dict(state["optimizer"])
        self.action_std = state["action_std"]
        self.actor.eval()


def train(
    config: ImitationConfig, run_dir: str | os.PathLike, resume: bool = False, progress: bool = True
) -> TrainResult:
    """Train (or, with ``resume``, go on training) ``config``'s policy in ``run_dir`` (the module
    docstring). Ctrl-C stops after the finished rounds and returns with ``interrupted=True``."""
    from tqdm import tqdm

    run_dir = Path(run_dir)
    torch.set_num_threads(config.threads)
    with run_dir_lock(run_dir), LocalExecutor(workers=config.cores) as executor:
        checkpoint = prepare_run_dir(config, run_dir, resume)
        rounds, learner, train_time = [], None, 0.0
        start = 0
        if checkpoint is not None:
            state = torch.load(checkpoint, weights_only=True)
            start, train_time = int(state["iteration"]), float(state["train_time"])
            rounds = [read_round(run_dir, index) for index in range(start)]
            learner = Learner(config, rounds[0]["observations"])
            if config.validation_episodes:  # interrupted before a validation, or validated before clean_score
                for iteration in range(1, start + 1):
                    learner.load(torch.load(checkpoint_path(run_dir, iteration), weights_only=True))
                    validate(config, run_dir, iteration, learner, executor)
            learner.load(state)
        metrics = [row for row in read_rows(run_dir / METRICS_FILE) if int(row["iteration"]) <= start]
        write_rows(run_dir / METRICS_FILE, METRICS_COLUMNS, metrics)
        bar = tqdm(total=config.iterations, initial=start, disable=not progress, desc=config.method)
        try:
            for iteration in range(start, config.iterations):
                began = time.perf_counter()
                rounds.append(collect_round(config, run_dir, iteration, learner, executor))
                learner = learner or Learner(config, rounds[0]["observations"])
                observations, labels = (
                    np.concatenate([r[key] for r in rounds]) for key in ("observations", "labels")
                )
                losses = learner.fit(config, iteration, observations, labels)
                train_time += time.perf_counter() - began
                save_checkpoint(learner, run_dir, iteration + 1, train_time)
                metrics.append(metrics_row(iteration + 1, rounds, losses, train_time))
                write_rows(run_dir / METRICS_FILE, METRICS_COLUMNS, metrics)
                if config.validation_episodes:
                    validate(config, run_dir, iteration + 1, learner, executor)
                bar.update()
        except KeyboardInterrupt:
            return TrainResult(run_dir, None, len(metrics), train_time, summary(metrics), interrupted=True)
        finally:
            bar.close()
        return conclude(config, run_dir, learner, metrics, train_time)


def collect_round(config: ImitationConfig, run_dir: Path, iteration: int, learner, executor) -> dict:
    """Round ``iteration``'s episodes (the learner drives with probability 1 - beta), saved and returned as
    arrays: per step ``observations`` (float16), ``labels``, ``executed``, ``by_expert`` and ``episode``
    (its index in the round); per episode its ``layouts``, ``seeds``, ``coverage`` and ``success``."""
    beta = config.beta(iteration)
    snapshot = learner_snapshot(learner.actor) if learner is not None and beta < 1.0 else None
    draws = np.random.default_rng([config.seed, iteration])
    names = suite_layout_names(config.suite) if config.suite else config.layouts
    jobs = []
    for episode in range(config.episodes_per_iteration):
        layout = names[draws.integers(len(names))] if config.suite else names[episode % len(names)]
        seed = TRAINING_SEED + int(draws.integers(1 << 30))
        jobs.append(EpisodeJob(episode, layout, seed, config.env_kwargs, beta, snapshot))
    results = sorted(executor.map(collect_episode, jobs), key=lambda data: data.job.episode)
    arrays = {
        "observations": np.concatenate([data.observations for data in results]).astype(np.float16),
        **{
            key: np.concatenate([getattr(data, key) for data in results])
            for key in ("labels", "executed", "by_expert")
        },
        "episode": np.concatenate([np.full(len(data.labels), index) for index, data in enumerate(results)]),
        "layouts": np.array([data.job.layout for data in results]),
        "seeds": np.array([data.job.seed for data in results]),
        "coverage": np.array([data.record["coverage"] for data in results]),
        "success": np.array([data.record["success"] for data in results], dtype=float),
    }
    folder = run_dir / DATA_DIR
    folder.mkdir(exist_ok=True)
    path = round_path(run_dir, iteration)
    temporary = path.with_name(path.stem + ".tmp.npz")
    np.savez_compressed(temporary, **arrays)
    os.replace(temporary, path)
    return arrays


def round_path(run_dir: Path, iteration: int) -> Path:
    return run_dir / DATA_DIR / f"round_{iteration:06d}.npz"


def read_round(run_dir: Path, iteration: int) -> dict:
    """The arrays ``collect_round`` saved for round ``iteration``."""
    with np.load(round_path(run_dir, iteration)) as data:
        return {key: data[key] for key in data.files}


def suite_layout_names(suite: str) -> list[str]:
    from cabinbench.layouts.suites import get_suite

    return get_suite(suite).layout_names


def save_checkpoint(learner: Learner, run_dir: Path, iteration: int, train_time: float) -> None:
    atomic_torch_save(
        {**learner.state(), "iteration": iteration, "train_time": train_time},
        checkpoint_path(run_dir, iteration),
    )


def metrics_row(iteration: int, rounds: list[dict], losses: tuple[float, float], train_time: float) -> dict:
    last = rounds[-1]
    return {
        "iteration": iteration,
        "episodes": len(last["coverage"]),
        "steps": len(last["labels"]),
        "expert_share": float(last["by_expert"].mean()),
        "fit_loss_first": losses[0],
        "fit_loss": losses[1],
        "coverage": float(last["coverage"].mean()),
        "success": float(last["success"].mean()),
        "timesteps": sum(len(r["labels"]) for r in rounds),
        "train_time": train_time,
    }


def validate(config: ImitationConfig, run_dir: Path, iteration: int, learner: Learner, executor) -> None:
    """Play checkpoint ``iteration``'s policy (mean actions) for one episode from a random start on each
    cabin-v1-val layout of ``config.validation_layouts`` (``validation.validation_rows``, as the rsl-rl
    trainer does); write a row per layout to ``validation.csv``, unless that checkpoint's rows are there
    with their ``clean_score`` (a resumed run). Rows without it are replaced."""
    path = run_dir / VALIDATION_FILE
    rows = read_rows(path)
    own = [row for row in rows if int(row["iteration"]) == iteration]
    if own and all(row.get("clean_score") not in (None, "") for row in own):
        return
    rows = [row for row in rows if int(row["iteration"]) != iteration]
    policy = export(config, learner, run_dir / VALIDATION_DIR / f"policy_{iteration:06d}.pt", {})
    env_kwargs = {"random_start": True, **({"max_steps": config.max_steps} if config.max_steps else {})}
    player = Player(config.method, str(policy), env_kwargs)
    plays = one_episode_each(config.validation_layouts)
    measured = validation_rows(iteration, plays, player, executor, SCORED_COLUMNS)
    kept = sorted(rows + measured, key=lambda row: int(row["iteration"]))  # stable: layouts keep their order
    write_rows(path, SCORED_COLUMNS, kept)


def export(config: ImitationConfig, learner: Learner, path: Path, training: dict) -> Path:
    """Write the learner's actor as the policy file ``path`` (``ppo_gail.policy``'s format)."""
    actor = learner.actor
    size = actor.mean.shape[1]
    return write_policy_file(
        path,
        actor.mlp,
        config.activation,
        ablation=config.policy_name,
        obs_normalizer={"mean": actor.mean[0].clone(), "std": actor.std[0].clone(), "eps": actor.eps},
        action_std=learner.action_std.clone(),
        observation_config=observation_config(config.env_kwargs, size),
        env_config={"layouts": config.layouts, "suite": config.suite, **config.env_kwargs},
        training=training,
    )


def conclude(
    config: ImitationConfig, run_dir: Path, learner: Learner, metrics: list[dict], train_time: float
) -> TrainResult:
    """Draw ``curves.png`` and export the chosen checkpoint (best on cabin-v1-val, or the last) as
    ``policy.pt``."""
    plot_curves(config, run_dir, metrics)
    validation = read_rows(run_dir / VALIDATION_FILE)
    last = int(metrics[-1]["iteration"])
    chosen = best_checkpoint(validation)[0] if config.export == "best" else last
    learner.load(torch.load(checkpoint_path(run_dir, chosen), weights_only=True))
    reached = {**summary(metrics), "exported_iteration": chosen}
    policy = export(config, learner, run_dir / POLICY_FILE, reached)
    return TrainResult(run_dir, policy, last, train_time, reached)


def plot_curves(config: ImitationConfig, run_dir: Path, metrics: list[dict]) -> None:
    """``curves.png``: per round the regression loss, the rounds' coverage and the expert's share of the
    steps, and the cabin-v1-val score of each checkpoint (``validation_score``)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    validation = read_rows(run_dir / VALIDATION_FILE)
    scored = sorted({int(row["iteration"]) for row in validation})
    panels = {
        "regression loss (last epoch)": [float(row["fit_loss"]) for row in metrics],
        "coverage of the round's episodes": [float(row["coverage"]) for row in metrics],
        "share of steps the expert drove": [float(row["expert_share"]) for row in metrics],
    }
    figure, axes = plt.subplots(1, 4, figsize=(16, 3.5))
    rounds = [int(row["iteration"]) for row in metrics]
    for axis, (title, values) in zip(axes, panels.items()):
        axis.plot(rounds, values, marker="o")
        axis.set_title(title)
    axes[3].plot(
        scored,
        [validation_score([r for r in validation if int(r["iteration"]) == i]) for i in scored],
        marker="o",
    )
    axes[3].set_title("cabin-v1-val: success + coverage")
    for axis in axes:
        axis.set_xlabel("iteration")
    figure.suptitle(f"{config.method} on {config.trained_on}")
    figure.tight_layout()
    figure.savefig(run_dir / CURVES_FILE, dpi=100)
    plt.close(figure)


def summary(metrics: list[dict]) -> dict:
    """The training summary: iterations, steps and seconds so far, the last round's coverage, success and
    regression loss."""
    if not metrics:
        return {
            "iterations": 0,
            "timesteps": 0,
            "train_time": 0.0,
            "final_coverage": None,
            "final_success": None,
        }
    last = metrics[-1]
    return {
        "iterations": int(last["iteration"]),
        "timesteps": int(last["timesteps"]),
        "train_time": float(last["train_time"]),
        "final_coverage": float(last["coverage"]),
        "final_success": float(last["success"]),
        "final_fit_loss": float(last["fit_loss"]),
    }


def export_latest(config: ImitationConfig, run_dir: str | os.PathLike) -> TrainResult:
    """Export the latest checkpoint of ``run_dir`` as its ``policy.pt`` without training."""
    run_dir = Path(run_dir)
    checkpoint = latest_checkpoint(run_dir)
    if checkpoint is None:
        raise FileNotFoundError(f"{run_dir} holds no checkpoint to export; train first")
    with run_dir_lock(run_dir):
        state = torch.load(checkpoint, weights_only=True)
        learner = Learner(config, read_round(run_dir, 0)["observations"])
        learner.load(state)
        metrics = [
            row for row in read_rows(run_dir / METRICS_FILE) if int(row["iteration"]) <= state["iteration"]
        ]
        reached = {**summary(metrics), "exported_iteration": int(state["iteration"])}
        policy = export(config, learner, run_dir / POLICY_FILE, reached)
    return TrainResult(run_dir, policy, int(state["iteration"]), float(state["train_time"]), reached)


def read_rows(path: Path) -> list[dict]:
    return read_metrics(path) if path.exists() else []


def write_rows(path: Path, columns, rows: list[dict]) -> None:
    """Write a CSV atomically: an interruption leaves the former rows."""
    temporary = path.with_name(path.name + ".tmp")
    with open(temporary, "w", newline="") as file:
        writer = csv.DictWriter(file, columns)
        writer.writeheader()
        writer.writerows(rows)
    os.replace(temporary, path)
