"""What training a ppo_gail baseline depends on the baseline for: ``TRAINERS`` maps each trainable baseline
to its ``Trainer``, which makes the run's config, names what its policy ships as and ships it.

- the ablations (``ppo_gail``, ``ppo``, ``ppo_icm``, ``ppo_gail_only``): ``TrainConfig`` of the ablation; on a
  suite the policy ships as ``<baseline>_suite``;
- ``ppo_gail_study``: the study's two networks, one per ``--stage`` (``study.study_config``), each shipped
  with its ``config.json`` and training summary beside it, as no ablation is;
- ``ppo_gail_team``: ``team_training.TeamTrainConfig``, whose own fields are options of it alone;
- ``ppo_lstm``: ``RecurrentTrainConfig``, PPO with an LSTM memory and no coverage patch;
- ``bc`` and ``dagger``: ``baselines.imitation``'s ``ImitationConfig`` and its own training loop.
"""

from __future__ import annotations

import json
import os
import shutil
from pathlib import Path

from cabinbench.baselines.imitation.config import ImitationConfig
from cabinbench.baselines.ppo_gail.algorithm import ABLATIONS
from cabinbench.baselines.ppo_gail.study import STAGES, stage_name, study_config
from cabinbench.baselines.ppo_gail.team_training import TEAM_POLICY, TeamTrainConfig
from cabinbench.baselines.ppo_gail.training.config import (
    CONFIG_FILE,
    METRICS_FILE,
    POLICY_FILE,
    VALIDATION_FILE,
    RecurrentTrainConfig,
    TrainConfig,
)
from cabinbench.baselines.ppo_gail.training.loop import TrainResult, export_latest, train

TRAINING_RECORDS = Path("results/training")  # what --ship and --keep keep of a run


class Trainer:
    """How one kind of learned baseline trains; the base is a baseline with a config class of its own."""

    config_class: type[TrainConfig] = TrainConfig
    stages: tuple[str, ...] = ()
    """The ``--stage`` values it needs one of; none: it takes no ``--stage``."""
    trains_on_suites = False

    def config(self, baseline: str, stage: str | None, given: dict) -> TrainConfig:
        """The run's config from the options ``given`` (fields of ``config_class``)."""
        return self.config_class(**given)

    def shipped_name(self, baseline: str, stage: str | None, suite: str | None) -> str:
        """What the run's policy ships as, and its run directory is named after."""
        return baseline

    def train(self, config: TrainConfig, run_dir: Path, resume: bool, progress: bool) -> TrainResult:
        """Train (or resume) the run of ``config`` in ``run_dir``: rsl-rl's (``training.loop.train``)."""
        return train(config, run_dir, resume=resume, progress=progress)

    def export_latest(self, config: TrainConfig, run_dir: Path) -> TrainResult:
        """Export the latest checkpoint of ``run_dir`` as its policy without training."""
        return export_latest(config, run_dir)

    def ship(self, result: TrainResult, name: str, ship_dir: Path, config: TrainConfig) -> str:
        """Copy the exported policy to ``ship_dir/<name>.pt`` and the run's records to
        ``results/training/<name>/``, from which the leaderboard draws the training curves; what was done."""
        shipped = ship_dir / f"{name}.pt"
        copy_policy(result.policy_path, shipped)
        records = TRAINING_RECORDS / name
        for record in training_records(config):
            copy_file(result.run_dir / record, records / record)
        return f"shipped: {shipped}; training records: {records}"


class AblationTrainer(Trainer):
    """The ablations: ``TrainConfig`` of the ablation, on layouts or on a suite."""

    trains_on_suites = True

    def config(self, baseline: str, stage: str | None, given: dict) -> TrainConfig:
        return TrainConfig(ablation=baseline, **given)

    def shipped_name(self, baseline: str, stage: str | None, suite: str | None) -> str:
        return f"{baseline}_suite" if suite else baseline


class StudyTrainer(Trainer):
    """The study's networks, one per stage; options not given take the study's configuration."""

    stages = STAGES

    def config(self, baseline: str, stage: str | None, given: dict) -> TrainConfig:
        return study_config(stage, **given)

    def shipped_name(self, baseline: str, stage: str | None, suite: str | None) -> str:
        return stage_name(stage)

    def ship(self, result: TrainResult, name: str, ship_dir: Path, config: TrainConfig) -> str:
        """As every trainer ships (its records beside the kept seeds', where the learning curves and the
        training cost read them), and besides the policy its ``config.json`` and training summary (steps,
        time, final metrics: how far it trained), which the reproduction report reads."""
        shipped = super().ship(result, name, ship_dir, config)
        copy_file(result.run_dir / CONFIG_FILE, ship_dir / f"{name}.config.json")
        reached = ship_dir / f"{name}.training.json"
        reached.write_text(json.dumps(result.summary, indent=2) + "\n")
        return f"{shipped}; its config and {reached.name} beside it"


class TeamTrainer(Trainer):
    """One policy shared by a team: ``TeamTrainConfig``."""

    config_class = TeamTrainConfig

    def shipped_name(self, baseline: str, stage: str | None, suite: str | None) -> str:
        return TEAM_POLICY


class RecurrentTrainer(Trainer):
    """``ppo_lstm``: ``RecurrentTrainConfig``, on layouts or on a suite."""

    config_class = RecurrentTrainConfig
    trains_on_suites = True


class ImitationTrainer(Trainer):
    """``bc`` and ``dagger``: ``ImitationConfig`` of the method, trained by ``baselines.imitation.training``
    (its checkpoint chosen on cabin-v1-val), on layouts or on a suite."""

    config_class = ImitationConfig
    trains_on_suites = True

    def config(self, baseline: str, stage: str | None, given: dict) -> ImitationConfig:
        return ImitationConfig(method=baseline, **given)

    def train(self, config: ImitationConfig, run_dir: Path, resume: bool, progress: bool) -> TrainResult:
        from cabinbench.baselines.imitation.training import train

        return train(config, run_dir, resume=resume, progress=progress)

    def export_latest(self, config: ImitationConfig, run_dir: Path) -> TrainResult:
        from cabinbench.baselines.imitation.training import export_latest

        return export_latest(config, run_dir)


TRAINERS: dict[str, Trainer] = {
    **{name: AblationTrainer() for name in sorted(ABLATIONS, key=lambda name: name != "ppo_gail")},
    "ppo_gail_study": StudyTrainer(),
    TEAM_POLICY: TeamTrainer(),
    "ppo_lstm": RecurrentTrainer(),
    "bc": ImitationTrainer(),
    "dagger": ImitationTrainer(),
}
"""Each trainable baseline's trainer: ``ppo_gail`` (ours) first, then its ablations, the study's, the
team's, the recurrent one's and the imitation learners'."""


def keep(result: TrainResult, name: str, config: TrainConfig) -> Path:
    """Copy the policy and the run's records to ``results/training/<name>/seed<S>/``: a further run of the
    same command, which ``scripts/make_results.sh`` scores into ``results/ablation.md``."""
    kept = TRAINING_RECORDS / name / f"seed{config.seed}"
    copy_policy(result.policy_path, kept / POLICY_FILE)
    for record in training_records(config):
        copy_file(result.run_dir / record, kept / record)
    return kept


def training_records(config: TrainConfig) -> tuple[str, ...]:
    """The files of a run that ``--ship`` and ``--keep`` keep beside its policy."""
    return (CONFIG_FILE, METRICS_FILE, *((VALIDATION_FILE,) if config.validation_episodes else ()))


def copy_policy(policy: Path, target: Path) -> None:
    """Copy a policy file and, where training wrote one, its ONNX twin beside it (``policy.onnx``)."""
    copy_file(policy, target)
    twin = policy.with_suffix(".onnx")
    if twin.exists():
        copy_file(twin, target.with_suffix(".onnx"))


def copy_file(source: Path, target: Path) -> None:
    """Copy atomically: a reader never sees a half-written file."""
    target.parent.mkdir(parents=True, exist_ok=True)
    temporary = target.with_name(target.name + ".tmp")
    shutil.copyfile(source, temporary)
    os.replace(temporary, target)
