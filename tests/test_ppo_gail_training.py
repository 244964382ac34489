"""The learned baselines' training: train, checkpoint, interrupt and resume, export, reload, evaluate.

A CI smoke test on tiny settings (8 envs x 16 steps, episodes of 30 steps), plus the exported actor against
rsl-rl's own inference policy, the errors of bad policy files, and the CLI's usage errors.
"""

from __future__ import annotations

import dataclasses
import json
import os
import shutil
import signal
import subprocess
import sys
import time
from pathlib import Path

os.environ.setdefault("GIT_PYTHON_REFRESH", "quiet")  # rsl-rl's logger imports GitPython

import numpy as np
import pytest
import torch
from cabinbench.baselines.imitation.config import ImitationConfig
from cabinbench.baselines.ppo_gail import training
from cabinbench.baselines.ppo_gail.algorithm import PPOCuriosityGail
from cabinbench.baselines.ppo_gail.policy import CHECKPOINT_DIR, PolicyFileError, read_policy_file
from cabinbench.baselines.ppo_gail.trainers import TRAINERS

from cabinbench import training_records
from cabinbench.agents import load_baseline
from cabinbench.envs.coverage_env import CoverageEnv
from cabinbench.episodes import run_episode
from tests.test_run_and_leaderboard import ctrl_c_as_in_a_terminal

SHIPPED = ("ppo_gail", "ppo", "ppo_icm", "ppo_gail_only")
COMMITTED_TRAINING = Path(__file__).resolve().parents[1] / "results" / "training"


def tiny_config(**overrides) -> training.TrainConfig:
    settings = dict(
        ablation="ppo_gail",
        layouts=["a320_cell"],
        num_envs=8,
        num_steps_per_env=16,
        iterations=3,
        max_steps=30,
        demo_episodes=2,
        save_interval=2,
        threads=1,
        hidden_dims=[32, 32],
        validation_episodes=2,
        validation_interval=2,
    )
    return training.TrainConfig(**{**settings, **overrides})


def interrupt_on_call(monkeypatch, call: int) -> None:
    """Make the ``call``-th ``runner.learn`` raise KeyboardInterrupt, as Ctrl-C would."""
    from rsl_rl.runners import OnPolicyRunner

    original, calls = OnPolicyRunner.learn, []

    def learn(self, *args, **kwargs):
        calls.append(1)
        if len(calls) == call:
            raise KeyboardInterrupt
        return original(self, *args, **kwargs)

    monkeypatch.setattr(OnPolicyRunner, "learn", learn)


def test_train_interrupt_resume_export_reload_and_evaluate(tmp_path, monkeypatch):
    run_dir = tmp_path / "run"

    # Ctrl-C during the third iteration: the checkpoint of iteration 2 is kept, nothing is exported.
    interrupt_on_call(monkeypatch, 3)
    interrupted = training.train(tiny_config(), run_dir, progress=False)
    assert interrupted.interrupted and interrupted.iterations == 2 and interrupted.policy_path is None
    assert [path.name for path in (run_dir / "checkpoints").iterdir()] == ["model_000002.pt"]
    assert not list(run_dir.rglob("*.tmp*"))
    rows_before = training_records.read_metrics(run_dir / "metrics.csv")
    assert [row["iteration"] for row in rows_before] == ["1", "2"]
    monkeypatch.undo()

    # Starting over in the same folder by mistake is refused; resuming continues from the checkpoint.
    with pytest.raises(FileExistsError, match="--resume"):
        training.train(tiny_config(), run_dir, progress=False)
    with pytest.raises(ValueError, match="num_envs"):
        training.train(tiny_config(num_envs=4), run_dir, resume=True, progress=False)
    loaded = []
    original_load = PPOCuriosityGail.load

    def recording_load(self, state, *args, **kwargs):
        loaded.append(state["iter"])
        return original_load(self, state, *args, **kwargs)

    monkeypatch.setattr(PPOCuriosityGail, "load", recording_load)
    # A run saved before a config field existed resumes with that field's default.
    saved = json.loads((run_dir / "config.json").read_text())
    del saved["demo_action_noise"]
    (run_dir / "config.json").write_text(json.dumps(saved))
    result = training.train(tiny_config(), run_dir, resume=True, progress=False)

    assert loaded == [2, 2, 3, 3]  # resumed from 2; each checkpoint validated; the last one exported
    assert read_policy_file(result.policy_path)["training"]["exported_iteration"] == 3
    assert not result.interrupted and result.iterations == 3
    rows = training_records.read_metrics(run_dir / "metrics.csv")
    assert [row["iteration"] for row in rows] == ["1", "2", "3"]
    assert rows[:2] == rows_before
    assert int(rows[-1]["timesteps"]) == 3 * 8 * 16
    assert float(rows[-1]["train_time"]) > float(rows[-2]["train_time"])
    for column in (
        "gail_discriminator",
        "curiosity_forward",
        "curiosity_inverse",
        "policy_loss",
        "value_loss",
    ):
        assert np.isfinite(float(rows[-1][column])), column
    assert any(row["episodes"] != "0" for row in rows)  # 30-step episodes end within the run
    checkpoint = torch.load(run_dir / "checkpoints" / "model_000003.pt", weights_only=True)
    assert checkpoint["iter"] == 3 and "discriminator_state_dict" in checkpoint
    assert (run_dir / "curves.png").stat().st_size > 10_000
    assert (run_dir / "demos" / "a320_cell.npz").is_file()

    # The exported policy is small, loads as a baseline and drives an episode.
    assert result.policy_path.stat().st_size < 500_000
    policy = read_policy_file(result.policy_path)
    assert policy["ablation"] == "ppo_gail" and policy["training"]["iterations"] == 3
    baseline = load_baseline("ppo_gail", checkpoint=str(result.policy_path))
    assert baseline.config == {"checkpoint": str(result.policy_path), "stochastic": True}
    record, trajectory = run_episode(
        "ppo_gail",
        "a320_cell",
        seed=0,
        env_kwargs={"max_steps": 40},
        config={"checkpoint": str(result.policy_path)},
    )
    assert record["steps"] == 40 and len(trajectory["positions"]) == 41
    assert record["path_length"] > 0


def test_a_run_interrupted_and_resumed_trains_exactly_the_policy_of_one_that_ran_through(
    tmp_path, monkeypatch, capsys
):
    """The checkpoint keeps the envs' episodes (here 2 steps into their second one), torch's random state
    and the logger's sums: the resumed iterations are those the run would have trained. (The run that goes
    through is "resumed" from nothing, as a sweep's unstarted run is: it says so and starts anew.)"""
    config = tiny_config(validation_episodes=0)
    through = training.train(config, tmp_path / "through", resume=True, progress=False)
    assert f"nothing to resume in {tmp_path / 'through'}: starting a new run" in capsys.readouterr().err
    interrupt_on_call(monkeypatch, 3)
    assert training.train(config, tmp_path / "resumed", progress=False).interrupted
    monkeypatch.undo()
    resumed = training.train(config, tmp_path / "resumed", resume=True, progress=False)

    def untimed_rows(result):
        rows = training_records.read_metrics(result.run_dir / "metrics.csv")
        return [{k: v for k, v in row.items() if k not in ("train_time", "iteration_time")} for row in rows]

    assert untimed_rows(resumed) == untimed_rows(through) and len(untimed_rows(through)) == 3

    def policy_values(result) -> dict:
        policy = read_policy_file(result.policy_path)
        return {
            **policy["actor"]["state_dict"],
            **policy["obs_normalizer"],
            "action_std": policy["action_std"],
        }

    values, values_through = policy_values(resumed), policy_values(through)
    assert values.keys() == values_through.keys()
    for name, value in values_through.items():
        same = torch.equal(values[name], value) if isinstance(value, torch.Tensor) else values[name] == value
        assert same, name


def test_every_checkpoint_is_validated_and_the_last_or_the_best_exported(tmp_path, monkeypatch):
    """Every ``validation_interval``-th checkpoint plays one episode on each layout of the cabin-v1-val
    sample, from a random start with seeds apart from the leaderboard's, and records the headline score.
    Ctrl-C during validation keeps the finished rows, and a resumed run plays only the checkpoints not yet
    validated. policy.pt is the last checkpoint's actor, or with export="best" (which a finished run may be
    resumed to change) the one with the best validation clean_score."""
    from cabinbench import episodes

    run_dir = tmp_path / "run"
    config = tiny_config(
        ablation="ppo",
        layouts=["a320_cell", "a320_tracking_cell"],
        iterations=4,
        save_interval=1,
        validation_interval=1,
        validation_episodes=2,
        workers=1,  # validation in this process, where the episodes are counted
    )
    played, original = [], episodes.run_episode

    def recording_run_episode(baseline, layout, seed, **kwargs):
        played.append((layout, seed, kwargs["env_kwargs"]))
        if len(played) == 5:  # the first episode of the third checkpoint
            raise KeyboardInterrupt
        return original(baseline, layout, seed, **kwargs)

    monkeypatch.setattr(episodes, "run_episode", recording_run_episode)
    interrupted = training.train(config, run_dir, progress=False)
    assert interrupted.interrupted and interrupted.iterations == 4 and interrupted.policy_path is None
    sample = training.suite_sample("cabin-v1-val", 2, training.VALIDATION_SEED)
    rows = training_records.read_metrics(run_dir / "validation.csv")
    assert [(row["iteration"], row["layout"]) for row in rows] == [
        (iteration, layout) for iteration in ("1", "2") for layout in sample
    ]
    seeds = [training.VALIDATION_SEED, training.VALIDATION_SEED + 1]
    random_start = {"random_start": True, "max_steps": 30}
    assert played[:4] == 2 * [(layout, seed, random_start) for layout, seed in zip(sample, seeds)]

    played.clear()
    result = training.train(config, run_dir, resume=True, progress=False)
    assert len(played) == 2 * 2  # checkpoints 3 and 4 only
    rows = training_records.read_metrics(run_dir / "validation.csv")
    assert [row["iteration"] for row in rows] == ["1", "1", "2", "2", "3", "3", "4", "4"]
    assert all(row["episodes"] == "1" and 0 < float(row["coverage"]) <= 1 for row in rows)
    assert all(0 < float(row["clean_score"]) < 0.5 for row in rows)  # none cleaned in 30 steps
    assert read_policy_file(result.policy_path)["training"]["exported_iteration"] == 4
    assert _same_actor(result.policy_path, run_dir / "validation" / "policy_000004.pt")
    assert (run_dir / "curves.png").stat().st_size > 10_000

    played.clear()
    result = training.train(dataclasses.replace(config, export="best"), run_dir, resume=True, progress=False)
    assert not played  # every checkpoint is validated already
    scores = {
        iteration: training_records.validation_score(
            [row for row in rows if row["iteration"] == str(iteration)]
        )
        for iteration in range(1, 5)
    }
    best = max(scores, key=lambda iteration: (scores[iteration], iteration))
    assert training_records.best_checkpoint(rows) == (best, scores[best])
    assert read_policy_file(result.policy_path)["training"]["exported_iteration"] == best
    assert _same_actor(result.policy_path, run_dir / "validation" / f"policy_{best:06d}.pt")
    other = next(iteration for iteration in scores if iteration != best)
    assert not _same_actor(result.policy_path, run_dir / "validation" / f"policy_{other:06d}.pt")

    # Finished, the run needs no checkpoint (a sweep's finished runs are kept without theirs): resumed, it
    # plays, trains and exports nothing and returns its policy; a config that differs is still refused.
    exported = result.policy_path.read_bytes()
    shutil.rmtree(run_dir / "checkpoints")
    best_config = dataclasses.replace(config, export="best")
    finished = training.train(best_config, run_dir, resume=True, progress=False)
    assert not played and finished.iterations == 4 and finished.policy_path.read_bytes() == exported
    assert finished.summary["exported_iteration"] == best and not (run_dir / "checkpoints").exists()
    with pytest.raises(ValueError, match="num_envs"):
        training.train(dataclasses.replace(best_config, num_envs=4), run_dir, resume=True, progress=False)


def _same_actor(path, other_path) -> bool:
    actor, other = (
        read_policy_file(path)["actor"]["state_dict"],
        read_policy_file(other_path)["actor"]["state_dict"],
    )
    return all(torch.equal(actor[key], other[key]) for key in actor)


def test_training_with_a_coverage_patch_keeps_it_from_the_icm_and_the_discriminator(tmp_path):
    """The actor sees the whole observation; the reward-shaping modules see every part of it but the patch."""
    config = tiny_config(coverage_patch=4, iterations=1, save_interval=1)
    result = training.train(config, tmp_path / "run", progress=False)
    env = CoverageEnv(config.layouts[0], **config.env_kwargs)
    sizes = {part: span.stop - span.start for part, span in env.observation_layout.items()}
    checkpoint = torch.load(tmp_path / "run" / "checkpoints" / "model_000001.pt", weights_only=True)
    shaping_inputs = sizes["lidar"] + sizes["velocity"]
    actions = env.action_space.shape[0]
    assert _input_size(checkpoint["discriminator_state_dict"]) == shaping_inputs + actions
    assert _input_size(checkpoint["curiosity_state_dict"]) == shaping_inputs
    exported = read_policy_file(result.policy_path)
    assert exported["actor"]["observation_size"] == sum(sizes.values()) == env.observation_space.shape[0]
    assert exported["observation_config"]["size"] == env.observation_space.shape[0]


def test_the_results_do_not_depend_on_the_cores_the_training_uses(tmp_path):
    """With ``workers=2`` the envs step in two processes and the ICM and the discriminator each train in a
    thread beside PPO: every metric and every tensor of every checkpoint (networks, optimisers, normalisers)
    is the one-core run's."""
    for workers in (1, 2):
        config = tiny_config(workers=workers, coverage_patch=4, validation_episodes=0)
        training.train(config, tmp_path / f"cores{workers}", progress=False)
    one, two = tmp_path / "cores1", tmp_path / "cores2"
    untimed = [
        [
            {k: v for k, v in row.items() if not k.endswith("time")}
            for row in training_records.read_metrics(run / "metrics.csv")
        ]
        for run in (one, two)
    ]
    assert untimed[0] == untimed[1] and len(untimed[0]) == 3
    assert (one / "config.json").read_text() == (two / "config.json").read_text()  # workers is not recorded
    checkpoints = sorted(path.name for path in (one / "checkpoints").glob("*.pt"))
    assert checkpoints == sorted(path.name for path in (two / "checkpoints").glob("*.pt")) and checkpoints
    for name in checkpoints:
        tensors = [_tensors(torch.load(run / "checkpoints" / name, weights_only=True)) for run in (one, two)]
        assert tensors[0].keys() == tensors[1].keys() and len(tensors[0]) > 20
        assert all(torch.equal(tensors[0][key], tensors[1][key]) for key in tensors[0]), name


def _tensors(value, path: str = "") -> dict[str, torch.Tensor]:
    """Every tensor in a nested checkpoint dict, by its path."""
    if isinstance(value, torch.Tensor):
        return {path: value}
    items = value.items() if isinstance(value, dict) else enumerate(value) if isinstance(value, list) else ()
    return {key: tensor for name, item in items for key, tensor in _tensors(item, f"{path}/{name}").items()}


def _input_size(state_dict: dict) -> int:
    """Inputs of a network's first layer: the first weight matrix in its state dict."""
    return next(value for key, value in state_dict.items() if key.endswith("weight")).shape[1]


def test_exported_actor_reproduces_rsl_rl_inference_policy(tmp_path):
    from cabinbench.baselines.ppo_gail.policy import export_policy
    from cabinbench.baselines.ppo_gail.runner_config import make_train_cfg
    from rsl_rl.runners import OnPolicyRunner
    from tensordict import TensorDict

    from cabinbench.envs.batched import BatchedCoverageEnv, RslRlVecEnv

    torch.manual_seed(0)
    batched = BatchedCoverageEnv("a320_cell", 4, seed=0, max_steps=50)
    env = RslRlVecEnv(batched)
    runner = OnPolicyRunner(
        env, make_train_cfg("ppo", num_steps_per_env=8, hidden_dims=[48, 24], activation="tanh"), log_dir=None
    )
    runner.learn(2)  # non-trivial weights and observation statistics
    path = export_policy(
        runner,
        tmp_path / "policy.pt",
        ablation="ppo",
        observation_config=batched.example_env.observation_config,
        env_config={},
        training={},
    )

    network = read_policy_file(path)["network"]
    reference = runner.get_inference_policy("cpu")
    generator = torch.Generator().manual_seed(1)
    observations = torch.rand(256, batched.observation_size, generator=generator) * 1.2 - 0.1
    with torch.no_grad():
        expected = reference(TensorDict({"policy": observations}, batch_size=[256]))
        actual = network(observations)
    assert torch.equal(actual, expected)
    assert not torch.equal(reference.obs_normalizer.std, torch.ones_like(reference.obs_normalizer.std))


def test_bad_policy_files_give_clear_errors(tmp_path):
    garbage = tmp_path / "garbage.pt"
    garbage.write_bytes(b"not a checkpoint")
    with pytest.raises(PolicyFileError, match="garbage.pt: cannot read the policy file"):
        read_policy_file(garbage)

    with pytest.raises(PolicyFileError, match="missing.pt: policy file not found.*--ship"):
        read_policy_file(tmp_path / "missing.pt")

    runner_checkpoint = tmp_path / "model.pt"
    torch.save({"actor_state_dict": {}, "iter": 3}, runner_checkpoint)
    with pytest.raises(
        PolicyFileError, match="not a cabinbench policy file.*full rsl-rl training checkpoint"
    ):
        read_policy_file(runner_checkpoint)

    policy = _small_policy(tmp_path)
    truncated = tmp_path / "truncated.pt"
    truncated.write_bytes(policy.read_bytes()[:2000])
    with pytest.raises(PolicyFileError, match="truncated.pt: cannot read"):
        read_policy_file(truncated)

    broken = torch.load(policy, weights_only=True)
    broken["actor"]["hidden_dims"] = [7]
    torch.save(broken, tmp_path / "broken.pt")
    with pytest.raises(PolicyFileError, match="broken.pt: malformed policy file"):
        read_policy_file(tmp_path / "broken.pt")

    # Trained with 64 rays; the env has 32.
    with pytest.raises(PolicyFileError, match="another observation layout.*n_rays: trained 64, env 32"):
        run_episode(
            "ppo",
            "a320_cell",
            seed=0,
            env_kwargs={"n_rays": 32, "max_steps": 5},
            config={"checkpoint": str(policy)},
        )
    # A 'ppo' policy is not a 'ppo_gail' one.
    with pytest.raises(PolicyFileError, match="holds a 'ppo' policy, not 'ppo_gail'"):
        run_episode(
            "ppo_gail", "a320_cell", seed=0, env_kwargs={"max_steps": 5}, config={"checkpoint": str(policy)}
        )


def test_stochastic_option_samples_the_trained_gaussian_reproducibly(tmp_path):
    policy = _small_policy(tmp_path)
    assert torch.equal(read_policy_file(policy)["action_std"], torch.ones(2))  # rsl-rl's init_std
    config = {"checkpoint": str(policy), "stochastic": True}
    episode = {"env_kwargs": {"max_steps": 30}}

    first, _ = run_episode("ppo", "a320_cell", seed=3, config=config, **episode)
    again, _ = run_episode("ppo", "a320_cell", seed=3, config=config, **episode)
    other, _ = run_episode("ppo", "a320_cell", seed=4, config=config, **episode)
    mean, _ = run_episode(
        "ppo", "a320_cell", seed=3, config={"checkpoint": str(policy), "stochastic": False}, **episode
    )

    assert first["path_length"] == again["path_length"]
    assert first["path_length"] != other["path_length"]
    assert first["path_length"] != mean["path_length"]
    assert load_baseline("ppo", **config).config == config


def test_a_learned_policy_leaves_the_process_torch_threads_alone(tmp_path):
    """The policy acts on one thread (fast for one observation), without setting the process's count."""
    config = {"checkpoint": str(_small_policy(tmp_path))}
    threads = torch.get_num_threads()
    torch.set_num_threads(2)
    try:
        run_episode("ppo", "a320_cell", seed=3, config=config, env_kwargs={"max_steps": 5})
        assert torch.get_num_threads() == 2
    finally:
        torch.set_num_threads(threads)


def test_a_policy_runs_in_the_observation_it_was_trained_on(tmp_path):
    """A policy trained with a coverage patch carries that setting: run_episode and the run CLI make the env
    with it, and the run's records say so."""
    policy = _small_policy(tmp_path, coverage_patch=4)
    baseline = load_baseline("ppo", checkpoint=str(policy))
    assert baseline.env_options["coverage_patch"] == 4
    record, _ = run_episode(
        "ppo", "a320_cell", seed=0, env_kwargs={"max_steps": 10}, config={"checkpoint": str(policy)}
    )
    assert record["steps"] == 10

    from cabinbench.commands.run import main as run_main

    out = tmp_path / "runs"
    assert (
        run_main(
            [
                "--baseline",
                "ppo",
                "--layout",
                "a320_cell",
                "--episodes",
                "1",
                "--max-steps",
                "10",
                "--config",
                json.dumps({"checkpoint": str(policy)}),
                "--out",
                str(out),
                "--json",
            ]
        )
        == 0
    )
    header = json.loads(next(out.glob("*.jsonl")).read_text().splitlines()[0])
    assert header["env_config"]["coverage_patch"] == 4


def _small_policy(tmp_path, **env_kwargs) -> os.PathLike:
    """An exported, untrained 'ppo' policy for the default 64-ray env (or one made with ``env_kwargs``)."""
    from cabinbench.baselines.ppo_gail.policy import export_policy
    from cabinbench.baselines.ppo_gail.runner_config import make_train_cfg
    from rsl_rl.runners import OnPolicyRunner

    from cabinbench.envs.batched import BatchedCoverageEnv, RslRlVecEnv

    batched = BatchedCoverageEnv("a320_cell", 2, seed=0, max_steps=20, **env_kwargs)
    runner = OnPolicyRunner(
        RslRlVecEnv(batched), make_train_cfg("ppo", num_steps_per_env=4, hidden_dims=[16]), log_dir=None
    )
    return export_policy(
        runner,
        tmp_path / "ppo.pt",
        ablation="ppo",
        observation_config=batched.example_env.observation_config,
        env_config={},
        training={},
    )


def test_train_cli_options_set_the_training_config(tmp_path):
    from cabinbench.baselines.ppo_gail.cli import build_config, parse_args

    config, run_dir = build_config(
        parse_args(
            [
                "--baseline",
                "ppo_icm",
                "--seed",
                "3",
                "--iterations",
                "7",
                "--random-start",
                "--coverage-patch",
                "8",
                "--coverage-patch-cell",
                "0.25",
                "--no-terminate-on-bound",
                "--reward",
                "paper",
                "--demo-episodes",
                "8",
                "--demo-action-noise",
                "0.3",
                "--algorithm",
                '{"gamma": 0.995}',
                "--run-dir",
                str(tmp_path),
            ]
        )
    )
    assert (config.ablation, config.seed, config.iterations) == ("ppo_icm", 3, 7)
    assert config.random_start and not config.terminate_on_bound and config.reward == "paper"
    assert (config.coverage_patch, config.coverage_patch_cell) == (8, 0.25)
    assert (config.demo_episodes, config.demo_action_noise) == (8, 0.3)
    assert config.algorithm == {"gamma": 0.995} and run_dir == tmp_path
    defaults, _ = build_config(parse_args(["--baseline", "ppo"]))
    assert defaults == training.TrainConfig(ablation="ppo")


def test_an_algorithm_that_leaves_out_a_default_setting_is_told_before_training():
    """``--algorithm`` replaces the baseline's algorithm settings: a run that leaves out one whose value there
    differs from the algorithm's default is told what it trains with instead and how to keep it; one that
    gives them, or no ``--algorithm``, or one that leaves out only what the default equals, hears nothing."""
    from cabinbench.baselines.ppo_gail.cli import parse_args, replaced_defaults

    def note(baseline: str, *options: str) -> str | None:
        args = parse_args(["--baseline", baseline, *options])
        return replaced_defaults(args, TRAINERS[args.baseline])

    assert note("ppo_gail", "--algorithm", '{"shaping_epochs": 1}') == (
        """note: --algorithm replaces ppo_gail's {"entropy_coef": 0.03, "gail_strength": 0.02}, so this """
        """run trains with "entropy_coef": 0.01, "gail_strength": 0.3 (the algorithm's defaults); give """
        """"entropy_coef": 0.03, "gail_strength": 0.02 in it to keep them"""
    )
    assert note("ppo", "--algorithm", '{"entropy_coef": 0.05}').endswith(
        'give "gail_strength": 0.02 in it to keep them'
    )
    assert (
        note("ppo_gail", "--algorithm", '{"entropy_coef": 0.03, "gail_strength": 0.02, "gamma": 0.9}') is None
    )
    assert note("ppo_gail") is None
    study = note("ppo_gail_study", "--stage", "cleaning", "--algorithm", '{"gail_strength": 0.3}')
    trains_with = study.split("trains with ")[1].split(" (the algorithm's defaults)")[0]
    assert '"curiosity_form"' in trains_with  # the study's is "mlagents", the algorithm's default is not
    assert '"entropy_coef"' not in trains_with  # the study's 0.01 is the default too
    assert '"gail_hidden_dims"' not in trains_with  # its [128, 128] is the default's (128, 128)


def test_committed_training_configs_read_back_as_they_were_written():
    """``config.json`` is the ``to_dict()`` of the baseline's trainer's config class (``TRAINERS``), which
    ``from_dict`` reads back (a resumed run, the leaderboard's reward-signal columns): every committed one
    (``results/training/<name>/[seed<S>/]config.json``, the study's a folder a stage) round-trips to the same
    bytes, an rsl-rl learner's with the ablation's ``use_curiosity`` and ``use_gail``."""
    paths = sorted(COMMITTED_TRAINING.rglob("config.json"))
    assert len(paths) >= 4
    for path in paths:
        shipped = path.relative_to(COMMITTED_TRAINING).parts[0]
        # ppo_gail_suite: ppo_gail's; ppo_gail_study_<stage>: the study's
        baseline = (
            "ppo_gail_study" if shipped.startswith("ppo_gail_study_") else shipped.removesuffix("_suite")
        )
        config_class = TRAINERS[baseline].config_class
        text = path.read_text()
        assert json.dumps(config_class.from_dict(json.loads(text)).to_dict(), indent=2) + "\n" == text, path
        if config_class is not ImitationConfig:
            assert {"use_curiosity", "use_gail"} <= json.loads(text).keys()  # what the leaderboard reads
    with pytest.raises(ValueError, match="unknown TrainConfig field.*'gail_strenght'"):
        training.TrainConfig.from_dict({**json.loads(text), "gail_strenght": 0.1})
    with pytest.raises(ValueError, match="unknown ablation 'nope'"):
        training.TrainConfig.from_dict({"ablation": "nope"})


def test_train_cli_rejects_unknown_baseline():
    completed = subprocess.run(
        [sys.executable, "-m", "cabinbench.train", "--baseline", "nope"],
        capture_output=True,
        text=True,
        timeout=60,
    )
    assert completed.returncode == 2
    assert "nope" in completed.stderr
    for name in SHIPPED:
        assert name in completed.stderr


def test_train_checks_the_algorithm_settings_before_any_work(tmp_path):
    """A misspelt ``--algorithm`` setting is one line naming it and the known ones, before the run starts."""
    completed = subprocess.run(
        [sys.executable, "-m", "cabinbench.train", "--baseline", "ppo", "--algorithm", '{"foo": 1}'],
        cwd=tmp_path,
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert completed.returncode == 2 and "Traceback" not in completed.stderr
    assert completed.stderr.startswith("error: algorithm: unknown setting(s) foo; known: ")
    assert "gail_strength" in completed.stderr and len(completed.stderr.splitlines()) == 1
    assert not (tmp_path / "runs").exists()


def test_a_run_folder_trains_in_one_process_at_a_time_and_ctrl_c_is_one_line(tmp_path):
    """A second ``train`` in a run folder that a process trains in is refused in one line (exit 2) and changes
    nothing there; Ctrl-C (SIGINT to the process group, as a terminal sends it) then stops the first in one
    line, exit 130."""
    command = [sys.executable, "-m", "cabinbench.train", "--baseline", "ppo", "--layout", "a320_cell"]
    command += [
        "--num-envs",
        "2",
        "--steps-per-env",
        "8",
        "--validation-episodes",
        "0",
        "--save-interval",
        "1",
    ]
    command += ["--workers", "1", "--no-progress", "--run-dir", "run"]
    first = subprocess.Popen(
        [*command, "--iterations", "1000"],
        cwd=tmp_path,
        stdout=subprocess.DEVNULL,
        stderr=subprocess.PIPE,
        text=True,
        start_new_session=True,
        preexec_fn=ctrl_c_as_in_a_terminal,
    )
    run = tmp_path / "run"
    deadline = time.monotonic() + 300
    while not list((run / "checkpoints").glob("*.pt")):
        assert first.poll() is None and time.monotonic() < deadline
        time.sleep(0.2)
    os.kill(first.pid, signal.SIGSTOP)  # the folder stands still while the second process tries
    try:
        before = {
            path: (path.stat().st_mtime_ns, path.read_bytes()) for path in run.rglob("*") if path.is_file()
        }
        for extra in ([], ["--resume"]):
            second = subprocess.run(
                [*command, "--iterations", "2", *extra],
                cwd=tmp_path,
                capture_output=True,
                text=True,
                timeout=120,
            )
            assert second.returncode == 2
            assert second.stderr.splitlines()[-1] == (
                f"error: run is being trained by another process (pid {first.pid}); "
                "wait for it or give another --run-dir"
            )
            assert "Traceback" not in second.stderr
        after = {
            path: (path.stat().st_mtime_ns, path.read_bytes()) for path in run.rglob("*") if path.is_file()
        }
        assert after == before
    finally:
        os.kill(first.pid, signal.SIGCONT)
    os.killpg(first.pid, signal.SIGINT)
    _, stderr = first.communicate(timeout=120)
    assert first.returncode == 130 and "Traceback" not in stderr
    assert (
        stderr.splitlines()[-1] == "interrupted: finished checkpoints are kept in run; continue with --resume"
    )
    assert stderr.count("interrupted") == 1


@pytest.mark.parametrize("name", SHIPPED)
def test_shipped_policy_drives_the_env_made_with_its_observation_settings(name):
    """``run --baseline NAME`` with no checkpoint: the shipped policy file loads, the env is made with the
    observation settings it was trained on, and the policy drives it and cleans some floor."""
    path = CHECKPOINT_DIR / f"{name}.pt"
    assert path.is_file(), (
        f"{path} is missing: train it with python -m cabinbench.train --baseline {name} --ship"
    )
    assert path.stat().st_size < 1_000_000
    policy = read_policy_file(path)
    assert policy["ablation"] == name and policy["training"]["iterations"] > 0
    # the baseline refuses an env whose observation differs from the policy's (PolicyFileError)
    record, trajectory = run_episode(name, "a320_cell", seed=0, env_kwargs={"max_steps": 60})
    assert record["steps"] == 60 and record["path_length"] > 0
    assert trajectory["coverage"][-1] > trajectory["coverage"][0]


def test_ship_installs_the_policy_and_keeps_its_training_records(tmp_path, monkeypatch):
    """``train --ship``: the policy lands where ``run --baseline`` finds it, and the run's config, metrics and
    validation land in results/training/, from which the leaderboard draws the committed training curve."""
    from cabinbench.commands import leaderboard
    from cabinbench.commands.train import main as train_main

    monkeypatch.chdir(tmp_path)
    (tmp_path / "checkpoints").mkdir()
    status = train_main(
        [
            "--baseline",
            "ppo",
            "--layout",
            "a320_cell",
            "--iterations",
            "2",
            "--num-envs",
            "4",
            "--steps-per-env",
            "8",
            "--max-steps",
            "20",
            "--run-dir",
            "run",
            "--ship",
            "--ship-dir",
            "checkpoints",
            "--no-progress",
        ]
    )
    assert status == 0
    assert read_policy_file(tmp_path / "checkpoints" / "ppo.pt")["ablation"] == "ppo"
    records = tmp_path / "results" / "training" / "ppo"
    assert len(training_records.read_metrics(records / "metrics.csv")) == 2
    validated = training_records.read_metrics(records / "validation.csv")
    assert {row["iteration"] for row in validated} == {"2"} and len(validated) == 10  # the last, 10 layouts
    # --keep: a further training seed's policy and records, beside the shipped run's
    status = train_main(
        [
            "--baseline",
            "ppo",
            "--layout",
            "a320_cell",
            "--iterations",
            "1",
            "--num-envs",
            "4",
            "--steps-per-env",
            "8",
            "--max-steps",
            "20",
            "--run-dir",
            "run3",
            "--seed",
            "3",
            "--keep",
            "--no-progress",
        ]
    )
    assert status == 0
    kept = records / "seed3"
    assert (
        read_policy_file(kept / "policy.pt")["ablation"] == "ppo"
        and json.loads((kept / "config.json").read_text())["seed"] == 3
    )
    assert len(training_records.read_metrics(kept / "metrics.csv")) == 1
    assert {row["iteration"] for row in training_records.read_metrics(kept / "validation.csv")} == {"1"}
    figures = leaderboard.training_figures(tmp_path / "results" / "training", tmp_path)
    assert [path.name for path in figures] == ["training__ppo.png"] and figures[0].stat().st_size > 10_000


def test_train_on_a_suite_records_it_resumes_and_ships_ppo_gail_suite(tmp_path, monkeypatch):
    """``train --baseline ppo_gail --suite cabin-v1-train`` on the real trainer (2 envs, a few iterations):
    the config, the training summary and the exported policy name the suite and its version; the expert
    demonstrates on a seeded handful of suite layouts; validation plays cabin-v1-val layouts; an interrupted
    suite run resumes; the policy ships as ``ppo_gail_suite``, which refuses a policy trained on cells."""
    from cabinbench.commands.train import main as train_main
    from cabinbench.layouts.suites import get_suite

    monkeypatch.chdir(tmp_path)
    (tmp_path / "checkpoints").mkdir()
    common = ["--baseline", "ppo_gail", "--suite", "cabin-v1-train", "--run-dir", "run", "--no-progress"]
    tiny = ["--num-envs", "2", "--steps-per-env", "8", "--max-steps", "12", "--save-interval", "1"]
    tiny += ["--demo-layouts", "2", "--demo-episodes", "1", "--validation-episodes", "2"]
    assert train_main([*common, *tiny, "--iterations", "2"]) == 0
    config = json.loads((tmp_path / "run" / "config.json").read_text())
    version = get_suite("cabin-v1-train").version
    assert (config["suite"], config["suite_version"], config["layouts"]) == ("cabin-v1-train", version, [])
    assert training.TrainConfig.from_dict(config).to_dict() == config
    demos = sorted(path.name for path in (tmp_path / "run" / "demos").glob("*.npz"))
    expected = training.suite_sample("cabin-v1-train", 2, 0)
    assert demos == [f"{name.split('/')[1]}.npz" for name in expected]
    validated = training_records.read_metrics(tmp_path / "run" / "validation.csv")
    assert {row["layout"] for row in validated} == set(
        training.suite_sample("cabin-v1-val", 2, training.VALIDATION_SEED)
    )

    # resumed to a third iteration, from the checkpoint of the second, and shipped as ppo_gail_suite
    assert train_main([*common, "--iterations", "3", "--resume", "--ship", "--ship-dir", "checkpoints"]) == 0
    assert [row["iteration"] for row in training_records.read_metrics(tmp_path / "run" / "metrics.csv")] == [
        "1",
        "2",
        "3",
    ]
    shipped = tmp_path / "checkpoints" / "ppo_gail_suite.pt"
    policy = read_policy_file(shipped)
    assert policy["ablation"] == "ppo_gail" and policy["training"]["iterations"] == 3
    assert (policy["env_config"]["suite"], policy["env_config"]["suite_version"]) == (
        "cabin-v1-train",
        version,
    )
    assert policy["training"]["suite"] == "cabin-v1-train"
    assert json.loads((tmp_path / "results/training/ppo_gail_suite/config.json").read_text())["suite"]
    record, _ = run_episode(
        "ppo_gail_suite",
        "cabin-v1-test/0003",
        seed=0,
        env_kwargs={"max_steps": 10},
        config={"checkpoint": str(shipped)},
    )
    assert record["steps"] == 10
    with pytest.raises(PolicyFileError, match="not on a suite; run it as --baseline ppo_gail"):
        load_baseline("ppo_gail_suite", checkpoint=str(CHECKPOINT_DIR / "ppo_gail.pt"))
    # a suite with --layout, or an unknown suite: one line, exit status 2
    assert train_main([*common[:4], "--layout", "a320_cell", "--run-dir", "other"]) == 2
    assert train_main(["--baseline", "ppo_gail", "--suite", "cabin-v9", "--run-dir", "other"]) == 2
