"""The validation protocol: nothing a training run chooses with reads cabin-v1-test, cabin-v1-ood or the
classic layouts. Real tiny runs of ``ppo_gail`` and ``bc`` (training, validation, ``--export best``) record
every layout their processes build, through the one class every loaded layout is, and the layouts must be
the run's training layouts and cabin-v1-val's."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import pytest
from cabinbench.baselines.ppo_gail.policy import read_policy_file
from cabinbench.baselines.ppo_gail.trainers import TRAINERS
from cabinbench.baselines.ppo_gail.training.config import VALIDATION_SUITE, TrainConfig

from cabinbench.layouts.suites import get_suite
from cabinbench.training_records import best_checkpoint, read_metrics

REPOSITORY = Path(__file__).resolve().parents[1]
NEVER_READ = ("cabin-v1-test", "cabin-v1-ood", "classic")
"""The suites no training choice may read: the leaderboard scores on them."""

RECORDER = """
import os

from cabinbench.layouts import model

built = model.Layout.__init__


def recording(self, *args, **kwargs):
    built(self, *args, **kwargs)
    with open(os.environ["CABINBENCH_LAYOUT_LOG"], "a") as log:
        log.write(self.name + "\\n")


model.Layout.__init__ = recording
"""
"""A ``sitecustomize`` module: every Python process of the run (the trainer and its workers, spawned or
forked) appends the name of every ``Layout`` it builds to the log. A layout is built wherever it is read:
by name, from a suite, from a file."""


def layouts_built(tmp_path: Path, baseline: str, run_dir: Path, *options: str) -> list[str]:
    """Train ``baseline`` with the train command in a fresh process (no layout cached) on 2 workers;
    the names of the layouts its processes built."""
    (tmp_path / "recorder").mkdir(exist_ok=True)
    (tmp_path / "recorder" / "sitecustomize.py").write_text(RECORDER)
    log = tmp_path / f"{baseline}.layouts"
    environment = {
        **os.environ,
        "PYTHONPATH": os.pathsep.join([str(tmp_path / "recorder"), str(REPOSITORY)]),
        "CABINBENCH_LAYOUT_LOG": str(log),
    }
    command = ["--baseline", baseline, "--run-dir", str(run_dir), "--workers", "2", "--no-progress"]
    completed = subprocess.run(
        [sys.executable, "-m", "cabinbench.train", *command, *options],
        env=environment,
        capture_output=True,
        text=True,
        cwd=tmp_path,
    )
    assert completed.returncode == 0, completed.stderr[-2000:]
    return log.read_text().split()


def held_out(names: list[str]) -> set[str]:
    """The names among ``names`` of layouts no training choice may read."""
    return set(names) & {name for suite in NEVER_READ for name in get_suite(suite).layout_names}


@pytest.mark.parametrize(
    "baseline, training_options",
    [
        (
            "ppo_gail",
            ["--num-envs", "2", "--steps-per-env", "8", "--demo-episodes", "1", "--validation-interval", "1"],
        ),
        ("bc", ["--episodes-per-iteration", "2"]),
    ],
)
def test_training_checkpoint_choice_and_export_read_only_training_and_validation_layouts(
    tmp_path, baseline, training_options
):
    """A run trained on one cabin-v1-train layout with ``--export best``: its processes build that layout
    and cabin-v1-val's (the validation sample, each checkpoint one episode from a random start) and no
    other; ``validation.csv`` names only cabin-v1-val layouts and records the headline score where the
    rsl-rl trainer chooses on it; the exported checkpoint is the best there."""
    training = "cabin-v1-train/0003"
    run_dir = tmp_path / "run"
    common = ["--layout", training, "--iterations", "2", "--max-steps", "40", "--validation-episodes", "3"]
    built = layouts_built(tmp_path, baseline, run_dir, *common, *training_options, "--export", "best")

    config = json.loads((run_dir / "config.json").read_text())
    sample = get_suite(VALIDATION_SUITE).layout_names
    assert held_out(built) == set()
    assert set(built) - set(sample) == {training}  # the training layout (and its demonstrations)
    validation = read_metrics(run_dir / "validation.csv")
    validated = [row["layout"] for row in validation]
    assert len(set(validated)) == 3 and set(validated) <= set(built) & set(sample)
    assert {row["iteration"] for row in validation} == {"1", "2"}
    if baseline == "ppo_gail":
        assert config["validation_suite"] == VALIDATION_SUITE and "clean_score" in validation[0]
    chosen = read_policy_file(run_dir / "policy.pt")["training"]["exported_iteration"]
    assert config["export"] == "best" and chosen == best_checkpoint(validation)[0]


@pytest.mark.parametrize("baseline", sorted(TRAINERS))
def test_every_trainer_validates_by_default_on_cabin_v1_val_only(baseline):
    """What each trainable baseline's default run is validated on: a sample of cabin-v1-val (but the study's
    tracking stage, whose episodes end at an exit cabin-v1-val's cells lack)."""
    trainer = TRAINERS[baseline]
    for stage in trainer.stages or (None,):
        config = trainer.config(baseline, stage, {})
        layouts = config.validation_layouts if config.validation_episodes else []
        assert set(layouts) <= set(get_suite(VALIDATION_SUITE).layout_names), (baseline, stage)
        assert bool(layouts) == (stage != "tracking"), (baseline, stage)


def test_a_config_json_written_before_the_protocol_reads_as_validated_on_its_training_layouts():
    """A ``config.json`` without ``validation_suite`` (here the one ppo_gail seed 0 wrote before the protocol,
    kept in tests/data) is a run validated on its training cells at every checkpoint; it reads back so and
    writes the same bytes; a new run records cabin-v1-val."""
    path = Path(__file__).parent / "data" / "config_before_validation_protocol.json"
    text = path.read_text()
    config = TrainConfig.from_dict(json.loads(text))
    assert config.validation_suite is None and config.validation_interval == config.save_interval
    assert config.validation_layouts == ["a320_cell", "a320_tracking_cell"]
    assert json.dumps(config.to_dict(), indent=2) + "\n" == text
    fresh = TrainConfig().to_dict()
    assert (fresh["validation_suite"], fresh["validation_interval"]) == (VALIDATION_SUITE, 200)
    assert TrainConfig.from_dict(fresh).to_dict() == fresh


def test_a_tracking_task_is_not_validated_on_cabin_v1_val():
    """Episodes that end at the exit (the study's tracking stage) have no task on cabin-v1-val's single
    cells: validating them there is refused, and the study's tracking stage validates nothing."""
    from cabinbench.baselines.ppo_gail.study import study_config

    with pytest.raises(ValueError, match="terminate_on_exit.*validation_episodes 0"):
        TrainConfig(terminate_on_exit=True)
    assert study_config("tracking").validation_episodes == 0
