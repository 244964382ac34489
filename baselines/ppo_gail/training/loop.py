"""The training loop: ``train(config, run_dir)`` records expert demonstrations with the boustrophedon planner
(or reuses given ``.npz`` files), builds ``RslRlVecEnv(BatchedCoverageEnv(...))`` and rsl-rl's
``OnPolicyRunner`` with the ``PPOCuriosityGail`` algorithm, then runs ``runner.learn(1)`` once per iteration
under a progress bar: a row of ``metrics.csv`` after each, a checkpoint every ``save_interval``; then it
validates the checkpoints on cabin-v1-val (``validation_interval``), draws ``curves.png`` and exports
``policy.pt``."""

from __future__ import annotations

import contextlib
import os
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import torch
from cabinbench.baselines.ppo_gail.runner_config import make_train_cfg
from cabinbench.baselines.ppo_gail.training.checkpoints import (
    check_resumable,
    checkpoint_path,
    latest_checkpoint,
    load_checkpoint,
    prepare_run_dir,
    resume_rollout,
    run_dir_lock,
    save_checkpoint,
)
from cabinbench.baselines.ppo_gail.training.config import (
    CURVES_FILE,
    DEMO_DIR,
    LINEAR_DECAY_FINAL,
    METRICS_FILE,
    POLICY_FILE,
    TrainConfig,
    default_run_dir,
)
from cabinbench.baselines.ppo_gail.training.metrics import (
    MetricsFile,
    TrainingLog,
    postfix,
    progress_bar,
    training_summary,
)
from cabinbench.baselines.ppo_gail.training.validation import read_validation, validate_checkpoints

from cabinbench.executors.local import LocalExecutor
from cabinbench.training_records import best_checkpoint, plot_curves, read_metrics


@dataclass
class TrainResult:
    run_dir: Path
    policy_path: Path | None  # None when the run was interrupted
    iterations: int  # completed
    train_time: float  # seconds spent in training iterations, over all sessions of the run
    summary: dict  # final training metrics (see ``training_summary``)
    interrupted: bool = False


def train(
    config: TrainConfig, run_dir: str | os.PathLike | None = None, resume: bool = False, progress: bool = True
) -> TrainResult:
    """Train (or, with ``resume``, continue training) the policy of ``config`` in ``run_dir``.

    Without ``resume`` the run directory must not hold checkpoints yet. With ``resume`` the saved
    ``config.json`` must agree with ``config`` except in ``RESUMABLE_CHANGES``; training continues from the
    latest checkpoint (or starts, if there is none), and a finished run (``finished_run``) is returned as it
    is. Another process training in ``run_dir`` meanwhile is a ``UsageError`` (``run_dir_lock``). Ctrl-C
    stops after the finished checkpoints and returns with ``interrupted=True`` (a second one, while the run
    is wound up, is raised).
    """
    run_dir = Path(run_dir) if run_dir is not None else default_run_dir(config)
    with run_dir_lock(run_dir):
        if resume and (result := finished_run(config, run_dir)) is not None:
            return result
        checkpoint = prepare_run_dir(config, run_dir, resume)
        runner, obs_config = build_runner(config, run_dir)
        initial = {name: getattr(runner.alg, name) for name in LINEAR_DECAY_FINAL}  # before a checkpoint's
        iteration, train_time = 0, 0.0
        if checkpoint is not None:
            state = load_checkpoint(runner, checkpoint)
            resume_rollout(runner, state, checkpoint)
            iteration, train_time = int(state["iter"]), float(state["infos"]["train_time"])
        iteration, train_time, interrupted = run_iterations(
            runner, config, run_dir, (iteration, train_time), initial, progress
        )
        return conclude(runner, config, obs_config, run_dir, (iteration, train_time), interrupted)


def finished_run(config: TrainConfig, run_dir: Path) -> TrainResult | None:
    """The result of the run in ``run_dir`` if it has finished ``config``, read from its ``policy.pt``; else
    None. Finished means trained for all ``config.iterations``, every checkpoint due validated, and the
    policy exported from the checkpoint ``config.export`` names. Such a run needs no checkpoint to be shipped
    or kept again, so a sweep's finished runs can be kept without theirs."""
    from cabinbench.baselines.ppo_gail.policy import read_policy_file

    path = run_dir / POLICY_FILE
    if not path.exists():
        return None
    check_resumable(config, run_dir)
    training = read_policy_file(path)["training"]
    if (
        training.get("iterations") != config.iterations
        or training.get("iterations_planned") != config.iterations
    ):
        return None
    validation = read_validation(run_dir, config)
    if config.validation_episodes:
        due = {*range(config.validation_interval, config.iterations + 1, config.validation_interval)}
        if {int(row["iteration"]) for row in validation} != due | {config.iterations}:
            return None
    exported = best_checkpoint(validation)[0] if config.export == "best" else config.iterations
    if training.get("exported_iteration") != exported:
        return None
    return TrainResult(run_dir, path, config.iterations, float(training["train_time_s"]), training)


def run_iterations(
    runner, config: TrainConfig, run_dir: Path, start: tuple[int, float], initial: dict, progress: bool
) -> tuple[int, float, bool]:
    """Train from ``start`` (iterations done, seconds of training so far) to ``config.iterations``, appending
    to ``metrics.csv`` and writing checkpoints; ``initial`` holds the values the "linear" schedule decays
    from. Returns the iterations and seconds reached, and whether Ctrl-C stopped it. The envs are closed at
    the end: validation plays episodes of its own."""
    iteration, train_time = start
    metrics = MetricsFile(run_dir / METRICS_FILE, keep_until=iteration)
    bar = progress_bar(config, iteration, progress)
    try:
        while iteration < config.iterations:
            runner.current_learning_iteration = iteration  # learn() numbers its iteration from here
            if config.learning_rate_schedule == "linear":
                decay_linearly(runner.alg, initial, iteration / config.iterations)
            runner.learn(num_learning_iterations=1)
            iteration += 1
            row = runner.logger.row
            train_time += row["iteration_time"]
            metrics.append({**row, "train_time": train_time})
            bar.update()
            bar.set_postfix(postfix(row), refresh=False)
            if saves_checkpoint(config, iteration):
                save_checkpoint(runner, run_dir, iteration, config, train_time)
    except KeyboardInterrupt:
        return iteration, train_time, True
    finally:
        bar.close()
        metrics.close()
        runner.env.close()
    return iteration, train_time, False


def conclude(
    runner,
    config: TrainConfig,
    obs_config: dict,
    run_dir: Path,
    reached: tuple[int, float],
    interrupted: bool,
) -> TrainResult:
    """Validate the checkpoints (unless ``interrupted``), draw the curves and export the policy of a run that
    ``reached`` (iterations, seconds of training)."""
    iteration, train_time = reached
    rows = read_metrics(run_dir / METRICS_FILE)
    summary = training_summary(rows, config, train_time)

    def export(path: Path, training: dict) -> Path:
        return export_run_policy(runner, config, obs_config, path, training)

    if not interrupted and config.validation_episodes:
        try:
            with LocalExecutor(workers=config.cores) as executor:  # the training envs are closed by now
                validate_checkpoints(runner, config, run_dir, lambda path: export(path, summary), executor)
        except KeyboardInterrupt:
            interrupted = True
    validation = read_validation(run_dir, config)
    if rows:
        plot_curves(
            rows,
            run_dir / CURVES_FILE,
            title=f"{config.policy_name} on {config.trained_on}",
            validation=validation,
        )
    if interrupted:
        return TrainResult(run_dir, None, iteration, train_time, summary, interrupted=True)
    exported = best_checkpoint(validation)[0] if config.export == "best" else iteration
    load_checkpoint(runner, checkpoint_path(run_dir, exported))  # validation left another one loaded
    summary["exported_iteration"] = exported
    policy_path = export(run_dir / POLICY_FILE, summary)
    return TrainResult(run_dir, policy_path, iteration, train_time, summary)


def saves_checkpoint(config: TrainConfig, iteration: int) -> bool:
    """Whether a checkpoint is written after ``iteration``: every ``save_interval`` iterations, where a
    checkpoint is validated (``validation_interval``) and after the last."""
    validated = config.validation_episodes and iteration % config.validation_interval == 0
    return iteration % config.save_interval == 0 or validated or iteration == config.iterations


def export_run_policy(runner, config: TrainConfig, obs_config: dict, path: Path, training: dict) -> Path:
    """Write the runner's current actor as the policy file ``path`` (``policy.export_policy``)."""
    from cabinbench.baselines.ppo_gail.policy import export_policy

    return export_policy(
        runner,
        path,
        ablation=config.policy_name,
        observation_config=obs_config,
        env_config={
            "layouts": config.layouts,
            "suite": config.suite,
            "suite_version": config.suite_version,
            **config.env_kwargs,
        },
        training=training,
    )


def export_latest(config: TrainConfig, run_dir: str | os.PathLike) -> TrainResult:
    """Export the latest checkpoint of ``run_dir`` as its ``policy.pt`` without training: the policy of a run
    stopped before its ``iterations`` (its training summary says how far it got; resume the run to go on)."""
    run_dir = Path(run_dir)
    checkpoint = latest_checkpoint(run_dir)
    if checkpoint is None:
        raise FileNotFoundError(f"{run_dir} holds no checkpoint to export; train first")
    with run_dir_lock(run_dir):
        runner, obs_config = build_runner(config, run_dir)
        state = load_checkpoint(runner, checkpoint)
        iteration, train_time = int(state["iter"]), float(state["infos"]["train_time"])
        rows = [row for row in read_metrics(run_dir / METRICS_FILE) if int(row["iteration"]) <= iteration]
        summary = training_summary(rows, config, train_time)
        summary["exported_iteration"] = iteration
        policy_path = export_run_policy(runner, config, obs_config, run_dir / POLICY_FILE, summary)
    runner.env.close()
    return TrainResult(run_dir, policy_path, iteration, train_time, summary)


def build_runner(config: TrainConfig, run_dir: Path):
    """The run's rsl-rl ``OnPolicyRunner`` (seeded; demonstrations recorded into ``run_dir`` if missing) and
    the training envs' observation config. Its logger is a ``TrainingLog``."""
    os.environ.setdefault("GIT_PYTHON_REFRESH", "quiet")  # rsl-rl's runner imports GitPython, which
    from rsl_rl.runners import OnPolicyRunner  # would refuse to load on a machine without git

    torch.set_num_threads(config.threads)
    torch.manual_seed(config.seed)
    np.random.seed(config.seed)

    demonstrations = expert_demonstrations(config, run_dir) if config.uses_gail else []
    env, obs_config, obs_layout = config.make_env()
    train_cfg = make_train_cfg(
        config.ablation,
        expert_demonstrations=demonstrations,
        expected_observation_config=obs_config,
        shaping_columns=shaping_columns(obs_layout),
        obs_groups=config.obs_groups,
        num_steps_per_env=config.num_steps_per_env,
        num_mini_batches=config.num_mini_batches,
        hidden_dims=config.hidden_dims,
        activation=config.activation,
        init_noise_std=config.init_noise_std,
        obs_normalization=config.obs_normalization,
        save_interval=config.save_interval,
        shaping_update_threads=config.cores - 1,
        **config.algorithm,
    )
    for model in ("actor", "critic"):
        train_cfg[model].update(config.model_settings)
    if config.min_action_std > 0:
        train_cfg["actor"]["distribution_cfg"]["std_range"] = [config.min_action_std, 1.0e6]
    with open(run_dir / "rsl_rl.log", "a") as log, contextlib.redirect_stdout(log):
        runner = OnPolicyRunner(env, train_cfg, log_dir=None, device="cpu")  # prints the models
    runner.logger = TrainingLog(env.num_envs, env.num_envs * config.num_steps_per_env)
    config.initialise(runner)

    return runner, obs_config


def decay_linearly(algorithm, initial: dict, progress: float) -> None:
    """Set PPO's learning rate, clip range and entropy coefficient ``progress`` (0 to 1) of the way from
    their ``initial`` values to ``LINEAR_DECAY_FINAL`` (rsl-rl's "fixed" schedule leaves them as set)."""
    for name, final in LINEAR_DECAY_FINAL.items():
        setattr(algorithm, name, final + (initial[name] - final) * (1.0 - progress))
    for group in algorithm.optimizer.param_groups:
        group["lr"] = algorithm.learning_rate


def shaping_columns(layout: dict[str, slice]) -> list[int] | None:
    """The observation columns the ICM and the discriminator see: every part of the observation's ``layout``
    but the coverage patch, whose expert sweep would give the expert away (``PPOCuriosityGail``); None (all
    columns) when there is no patch."""
    if "coverage_patch" not in layout:
        return None
    kept = [span for part, span in layout.items() if part != "coverage_patch"]
    return [column for span in kept for column in range(span.start, span.stop)]


def expert_demonstrations(config: TrainConfig, run_dir: Path) -> list[str]:
    """The given ``.npz`` files, or boustrophedon demonstrations of every layout of ``demo_layout_names``
    recorded into ``run_dir/demos`` (kept, so a resumed run imitates the same data)."""
    from cabinbench.baselines.boustrophedon import record_demonstrations

    if config.demonstrations:
        return [str(path) for path in config.demonstrations]
    folder = run_dir / DEMO_DIR
    folder.mkdir(exist_ok=True)
    paths = []
    for layout in dict.fromkeys(config.demo_layout_names):
        path = folder / f"{Path(layout).stem}.npz"  # a suite layout's: its number
        if not path.exists():
            temporary = folder / f"{Path(layout).stem}.tmp.npz"
            env_kwargs = {
                **config.env_kwargs,
                "max_steps": config.demo_max_steps or config.max_steps,
                "random_start": config.demo_random_start,
            }
            record_demonstrations(
                layout,
                config.demo_episodes,
                str(temporary),
                seed=config.first_env_seed,
                action_noise=config.demo_action_noise,
                **env_kwargs,
            )
            os.replace(temporary, path)
        paths.append(str(path))
    return paths
