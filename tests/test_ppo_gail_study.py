"""``ppo_gail_study``: the study's configuration, its two trainings, the pair run cell by cell, and the
generated table of differences.

The training smoke test keeps the study's networks, rewards, observation and schedule, on tiny rollouts and
a few iterations.
"""

from __future__ import annotations

import json
import os
from pathlib import Path

os.environ.setdefault("GIT_PYTHON_REFRESH", "quiet")  # rsl-rl's logger imports GitPython

import numpy as np
import pytest
from cabinbench.baselines.boustrophedon import Boustrophedon
from cabinbench.baselines.ppo_gail import cli, differences, training
from cabinbench.baselines.ppo_gail.policy import read_policy_file, tracking_or_cleaning
from cabinbench.baselines.ppo_gail.study import STAGES, stage_name, study_config
from cabinbench.baselines.ppo_gail.training.loop import expert_demonstrations

from cabinbench.agents import EpisodeContext, load_baseline
from cabinbench.envs.coverage_env import CoverageEnv
from cabinbench.episodes import run_episode
from cabinbench.layouts.resolve import load_layout
from cabinbench.training_records import read_metrics
from tests.test_ppo_gail_training import interrupt_on_call

REPOSITORY = Path(__file__).resolve().parents[1]


def test_the_study_config_is_tables_5_2_and_5_3_with_the_papers_rewards_and_lidar_only():
    for stage, layout, steps, exits, demos in (
        ("cleaning", "a320_cell", 6_000_000, False, 34),
        ("tracking", "a320_tracking_cell", 2_000_000, True, 32),
    ):
        config = study_config(stage)
        buffer = config.num_envs * config.num_steps_per_env
        assert config.layouts == [layout] and config.reward == "paper" and config.coverage_patch == 0
        assert (buffer, buffer // config.num_mini_batches, config.num_steps_per_env) == (2048, 128, 128)
        assert config.hidden_dims == [512, 512] and not config.obs_normalization
        assert 0 <= config.iterations * buffer - steps < buffer  # max_steps, in whole updates
        assert (
            config.terminate_on_bound and config.terminate_on_exit == exits and config.demo_episodes == demos
        )
        assert config.learning_rate_schedule == "linear" and config.min_action_std == 0
        algorithm = config.algorithm
        assert (algorithm["gail_strength"], algorithm["curiosity_strength"], algorithm["entropy_coef"]) == (
            0.3,
            0.02,
            0.01,
        )
        assert (algorithm["learning_rate"], algorithm["curiosity_encoding_size"]) == (3e-4, 256)
        # the reward signals as ML-Agents, the study's toolkit, computes them, with its defaults
        assert (algorithm["curiosity_form"], algorithm["gail_form"]) == ("mlagents", "mlagents")
        assert not algorithm["gail_use_actions"] and algorithm["gail_gradient_penalty"] == 10
        assert algorithm["gail_learning_rate"] == algorithm["curiosity_learning_rate"] == 3e-4
        assert algorithm["value_per_signal"]  # ML-Agents' critic: a value head per reward signal
        assert config.demo_random_start and config.demo_action_noise > 0  # varied demonstrations


def test_the_tracking_episode_ends_at_the_exit_landmark():
    env = CoverageEnv("a320_tracking_cell", terminate_on_exit=True, terminate_on_bound=True)
    observation, info = env.reset(seed=0)
    planner = Boustrophedon()
    planner.reset(EpisodeContext(env.layout, "sequential", 0), observation, info)
    total, terminated, truncated = 0.0, False, False
    while not (terminated or truncated):
        observation, reward, terminated, truncated, info = env.step(planner.act(observation, info))
        total += reward
    assert terminated and info["current_cell"] == 1 and info["cells_cleared"] == 0
    assert reward == pytest.approx(2.0 - 0.01)  # Table 4.5: reach guidance +2, step cost -0.01
    assert info["steps"] < 100


def tiny(stage: str, **overrides) -> training.TrainConfig:
    """The study's configuration on tiny rollouts: 4 envs x 16 steps, 4 mini-batches, 3 iterations."""
    settings = dict(num_envs=4, num_steps_per_env=16, num_mini_batches=4, iterations=3, save_interval=1)
    return study_config(stage, **{**settings, "demo_episodes": 1, "max_steps": 60, **overrides})


def test_the_study_demonstrations_are_varied_episodes_not_one_repeated(tmp_path):
    """Each episode from another start pose, the path perturbed: no two episodes alike."""
    config = tiny("cleaning", demo_episodes=3, max_steps=200)
    (path,) = expert_demonstrations(config, tmp_path)
    with np.load(path) as data:
        observations, episode = data["observations"], data["episode"]
    episodes = [observations[episode == index] for index in range(3)]
    firsts = [tuple(steps[0]) for steps in episodes]
    assert len(set(firsts)) == 3  # three start poses
    assert not np.array_equal(episodes[0][:50], episodes[1][:50])


def test_the_study_forms_train_the_same_on_one_core_or_two(tmp_path):
    """With two cores the ICM and the discriminator train in threads; ML-Agents' gradient penalty draws its
    interpolation before the update, so the run is the one-core run's."""
    for workers in (1, 2):
        config = tiny("cleaning", iterations=2, workers=workers, validation_episodes=0, export="last")
        training.train(config, tmp_path / f"cores{workers}", progress=False)
    rows = [
        [
            {key: value for key, value in row.items() if not key.endswith("time")}
            for row in read_metrics(tmp_path / f"cores{workers}" / "metrics.csv")
        ]
        for workers in (1, 2)
    ]
    assert rows[0] == rows[1] and len(rows[0]) == 2
    assert float(rows[0][1]["gail_reward"]) > 0  # ML-Agents' -log(1 - D), once D has trained


def test_study_training_checkpoints_exports_and_runs_the_pair_cell_by_cell(tmp_path, monkeypatch):
    policies = {}
    for stage in STAGES:
        run_dir = tmp_path / stage
        interrupt_on_call(monkeypatch, 3)  # Ctrl-C in the third iteration
        assert training.train(tiny(stage), run_dir, progress=False).iterations == 2
        monkeypatch.undo()
        # resumed: ML-Agents' linear decay goes on from the checkpoint
        training.train(tiny(stage), run_dir, resume=True, progress=False)
        rates = [float(row["learning_rate"]) for row in read_metrics(run_dir / "metrics.csv")]
        assert rates == pytest.approx([3e-4, 2e-4, 1e-4], rel=1e-6)
        # a run stopped early ships its latest checkpoint, labelled with the steps it reached
        (run_dir / "config.json").write_text(json.dumps(tiny(stage, iterations=5).to_dict()))
        ship = ["--run-dir", str(run_dir), "--export-latest", "--ship", "--ship-dir", str(tmp_path)]
        monkeypatch.chdir(tmp_path)  # --ship keeps the run's records in results/training/
        assert cli.main(["--baseline", "ppo_gail_study", "--stage", stage, *ship]) == 0
        assert (tmp_path / "results" / "training" / f"ppo_gail_study_{stage}" / "metrics.csv").is_file()
        reached = json.loads((tmp_path / f"ppo_gail_study_{stage}.training.json").read_text())
        assert (reached["iterations"], reached["iterations_planned"], reached["timesteps"]) == (3, 5, 3 * 64)
        assert (tmp_path / f"ppo_gail_study_{stage}.config.json").exists()
        policies[stage] = str(tmp_path / f"ppo_gail_study_{stage}.pt")

    # The pair: the tracking network acts while the current cell is clean, the cleaning network otherwise.
    study = load_baseline("ppo_gail_study", **policies)
    assert study.env_options["coverage_patch"] == 0
    for layout, first_stage in (("a320_tracking_cell", "tracking"), ("a320_cell", "cleaning")):
        record, _ = run_episode("ppo_gail_study", layout, 0, env_kwargs={"max_steps": 40}, config=policies)
        env = CoverageEnv(layout, **study.env_options)
        observation, info = env.reset(seed=0)
        study.reset(
            EpisodeContext(env.layout, "sequential", 0, env_config=study.env_options), observation, info
        )
        action = study.act(observation, info)
        assert study.stage == first_stage and np.all(np.abs(action) <= 1)
        again, _ = run_episode("ppo_gail_study", layout, 0, env_kwargs={"max_steps": 40}, config=policies)
        assert again["coverage"] == record["coverage"]  # reproducible


def test_the_stage_follows_the_protocols_state():
    cabin = load_layout("full_cabin")
    context = EpisodeContext(cabin, "sequential", 0)
    assert tracking_or_cleaning(context, {"cells_cleared": 0, "current_cell": 0}) == "cleaning"
    assert tracking_or_cleaning(context, {"cells_cleared": 1, "current_cell": 0}) == "tracking"
    assert tracking_or_cleaning(context, {"cells_cleared": 1, "current_cell": 1}) == "cleaning"
    open_protocol = EpisodeContext(cabin, "open", 0)
    assert tracking_or_cleaning(open_protocol, {"cells_cleared": 3, "current_cell": 0}) == "cleaning"
    tracking_cell = EpisodeContext(load_layout("a320_tracking_cell"), "sequential", 0)
    assert tracking_or_cleaning(tracking_cell, {"cells_cleared": 0, "current_cell": 0}) == "tracking"


def test_the_train_command_needs_a_stage_for_the_study_and_only_for_it(capsys):
    assert cli.main(["--baseline", "ppo_gail_study"]) == cli.EXIT_USAGE
    assert cli.main(["--baseline", "ppo_gail", "--stage", "cleaning"]) == cli.EXIT_USAGE
    assert capsys.readouterr().err.count("--stage cleaning|tracking") == 2


def test_cli_builds_the_study_config_of_the_stage(tmp_path):
    args = cli.parse_args(["--baseline", "ppo_gail_study", "--stage", "tracking", "--seed", "3"])
    config, run_dir = cli.build_config(args)
    assert config.to_dict() == study_config("tracking", seed=3).to_dict()
    assert run_dir == Path("runs/train/ppo_gail_study_tracking__seed3")


def test_the_committed_differences_table_is_the_generated_one(tmp_path):
    out = tmp_path / "differences.md"
    assert differences.main(["--out", str(out)]) == 0
    assert out.read_text() == (REPOSITORY / "results" / "differences.md").read_text()
    rows = {row["setting"]: row for row in differences.table_rows()}
    assert rows["GAIL strength"]["ppo_gail"] == "0.02" and rows["GAIL strength"]["ppo_gail_study"] == "0.3"
    assert (
        rows["mini-batch (batch_size)"]["ppo_gail"] == "1024"
        and rows["training steps"]["ppo_gail"] == "3.28 M"
    )


def installed_pairs() -> dict[int, dict[str, tuple[Path, Path]]]:
    """Each training seed's pair as scripts/train_study_policies.sh installs it, stage by stage: its
    ``config.json`` and policy file, seed 0's shipped, every further seed's kept."""
    shipped = REPOSITORY / "baselines" / "ppo_gail" / "checkpoints"
    pairs = {
        0: {
            stage: (shipped / f"{stage_name(stage)}.config.json", shipped / f"{stage_name(stage)}.pt")
            for stage in STAGES
        }
    }
    for kept in sorted((REPOSITORY / "results" / "training" / stage_name("cleaning")).glob("seed*")):
        seed = int(kept.name.removeprefix("seed"))
        folders = {
            stage: REPOSITORY / "results" / "training" / stage_name(stage) / kept.name for stage in STAGES
        }
        pairs[seed] = {
            stage: (folder / "config.json", folder / "policy.pt") for stage, folder in folders.items()
        }
    return pairs


def test_every_installed_pair_is_the_study_config_of_its_seed_trained_to_all_its_steps():
    """Three training seeds, each pair the study's configuration of its seed (ML-Agents' reward signals and
    critic, varied demonstrations, the cleaning checkpoint chosen on cabin-v1-val), run to its planned
    steps; the shipped pair's summary beside it is the one its policy file records."""
    pairs = installed_pairs()
    assert sorted(pairs) == [0, 1, 2]
    for seed, pair in pairs.items():
        for stage, (config_file, policy_file) in pair.items():
            config = training.TrainConfig.from_dict(json.loads(config_file.read_text()))
            assert config.to_dict() == study_config(stage, seed=seed).to_dict()
            reached = read_policy_file(policy_file)["training"]
            assert reached["iterations"] == reached["iterations_planned"] == config.iterations
            assert reached["timesteps"] == config.iterations * 2048
    checkpoints = REPOSITORY / "baselines" / "ppo_gail" / "checkpoints"
    for stage in STAGES:
        summary = json.loads((checkpoints / f"{stage_name(stage)}.training.json").read_text())
        assert summary == read_policy_file(checkpoints / f"{stage_name(stage)}.pt")["training"]
