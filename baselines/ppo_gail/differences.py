"""Every difference between ``ppo_gail`` (our tuned variant), ``ppo_gail_study`` and the study, as one table.

    python -m cabinbench.baselines.ppo_gail.differences [--out results/differences.md] [--shipped-config FILE]

The values are read, never typed: ``ppo_gail``'s from the ``config.json`` its shipped policy was trained with
(``SHIPPED_CONFIG``: ``TrainConfig``'s defaults and the training script's options), ``ppo_gail_study``'s from
``study.study_config`` of each stage, and the study's from ``study.STUDY``; the algorithm's settings not in a
config are ``PPOCuriosityGail``'s and ``STUDY_PPO``'s defaults. Only the reasons are written here, beside the
setting they explain, and the generator refuses a reason for a value that does not differ or a difference
without its reason. A few settings are not configuration but code (who demonstrates, the GAIL reward's form,
how the pair is run); their rows say so.
"""

from __future__ import annotations

import dataclasses
import inspect
import json
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

from cabinbench.baselines.ppo_gail.algorithm import STUDY_PPO, PPOCuriosityGail
from cabinbench.baselines.ppo_gail.study import STAGES, STUDY, study_config
from cabinbench.baselines.ppo_gail.training.config import TrainConfig

from cabinbench.cli import ArgumentParser, output_file, user_errors
from cabinbench.envs.settings import EnvSettings
from cabinbench.sim.observation import LIDAR_CHANNELS

N_RAYS = EnvSettings.n_rays  # the lidar every variant trains with
DEFAULT_OUT = "results/differences.md"
SHIPPED_CONFIG = Path("results/training/ppo_gail/config.json")  # the shipped ppo_gail's training config


def derived(values: dict) -> dict:
    """A config's ``values`` with the quantities the study states instead: samples per update, mini-batch
    size, training steps, observation size."""
    buffer = values["num_envs"] * values["num_steps_per_env"]
    return {
        **values,
        "buffer": buffer,
        "mini_batch": buffer // values["num_mini_batches"],
        "steps": buffer * values["iterations"],
        "observation_size": N_RAYS * len(LIDAR_CHANNELS) + values["coverage_patch"] ** 2 + 2,
    }


def config_settings(config: TrainConfig) -> dict:
    """A config's fields, its algorithm's settings (with the defaults it leaves) and the derived ones."""
    defaults = {
        name: parameter.default
        for name, parameter in inspect.signature(PPOCuriosityGail.__init__).parameters.items()
        if parameter.default is not inspect.Parameter.empty
    }
    return derived({**dataclasses.asdict(config), **defaults, **STUDY_PPO, **config.algorithm})


def study_settings(stage: str) -> dict:
    return {name: stated.of(stage) for name, stated in STUDY.items()}


def _steps(steps: int) -> str:
    return f"{steps / 1e6:.2f} M"


def _layers(dims) -> str:
    return f"{len(dims)} x {dims[0]}"


def _yes_no(value: bool) -> str:
    return "yes" if value else "no"


@dataclass(frozen=True)
class Row:
    """A setting read from the configs (``key`` in ``config_settings`` / ``study_settings``), shown by
    ``show``; ``why`` gives, per variant, the reason it differs from the study (or, where the study is
    silent, why it has its value)."""

    setting: str
    key: str
    show: Callable[[object], str] = str
    why_ppo_gail: str = ""
    why_study: str = ""


@dataclass(frozen=True)
class CodeRow:
    """A setting fixed in code rather than configuration: its values are stated here."""

    setting: str
    study: str  # "not stated" where the study does not give it
    ppo_gail_study: str
    ppo_gail: str
    source: str = ""  # where the study states its value
    why_ppo_gail: str = ""
    why_study: str = ""


UNTESTED = "chosen for a CPU's throughput; no trial against the study's value is recorded"
PLANNER_EXPERT = "no human demonstrations are public; the planner is the expert the benchmark has"
CHECKPOINT_PROTOCOL = (
    "the benchmark's protocol: a learner's checkpoint is chosen on cabin-v1-val "
    "(docs/experiments.md, Choosing on `cabin-v1-val`)"
)

CURIOSITY_FORMS = {
    "mlagents": "ML-Agents': clip(strength x forward error, 0, 1); loss 10 (0.2 L_F + 0.8 L_I); encoder "
    "2 swish layers, models 1 x 256 (mlagents.py)",
    "ours": "strength x forward error / its running std; loss 0.2 L_F + 0.8 L_I; encoder, models 1 x 256 ELU",
}
GAIL_FORMS = {
    "mlagents": "ML-Agents': -log(1 - D + 1e-7), WGAN-GP penalty between agent and expert samples "
    "(mlagents.py)",
    "ours": "logit log D - log(1 - D), centred on the rollout's mean; R1 penalty at the expert samples",
}

ROWS: list[Row | CodeRow] = [
    CodeRow(
        "networks trained",
        "two, apart: cleaning and tracking",
        "two, apart: cleaning and tracking",
        "one, on both cells at once (half the envs each)",
        source="§4.3.3, §5.2.1",
        why_ppo_gail="one policy tells cleaning from tracking by what its lidar sees, so it runs a cabin "
        "zero-shot with no switch (training.py)",
    ),
    Row("training layouts", "layouts", " + ".join, why_ppo_gail="one policy learns both tasks"),
    Row(
        "reward",
        "reward",
        why_ppo_gail="the dense `coverage` preset pays for area, what the benchmark scores; with `paper` "
        "the episode ends at the last goal marker and trial policies covered less (docs/experiments.md, "
        "Reward preset)",
    ),
    Row(
        "episode ends on a bound contact",
        "terminate_on_bound",
        _yes_no,
        why_ppo_gail="ending the episode was an exit from the mostly negative GAIL reward: trial agents "
        "drove into the bound (docs/experiments.md, Ending episodes on a bound)",
    ),
    Row(
        "episode ends at the exit landmark",
        "terminate_on_exit",
        _yes_no,
        why_ppo_gail="one policy goes on to clean the next cell, as it must in a cabin",
    ),
    Row(
        "coverage patch in the observation (cells across)",
        "coverage_patch",
        why_ppo_gail="lidar alone cannot tell a cleaned aisle from a dirty one: every lidar-only policy "
        "covered 0.40-0.64 of a320_cell (docs/experiments.md, Coverage patch). The study avoided maps on "
        "purpose (§4.3.2)",
    ),
    Row(
        "observation size",
        "observation_size",
        why_ppo_gail="64 lidar rays x 6 values, the coverage patch, speed and turn rate",
        why_study="the benchmark's lidar: 64 rays, each a distance and a one-hot of 5 tags. The study gives "
        "244 inputs but not its ray count; its velocity is a world-frame Vector3 (x, 0, z), ours the "
        "robot's speed and turn rate",
    ),
    Row(
        "hidden layers (actor and critic)",
        "hidden_dims",
        _layers,
        why_ppo_gail="small networks: on a CPU the update dominates the iteration time (training.py)",
    ),
    Row(
        "activation", "activation", why_ppo_gail="rsl-rl's default", why_study="not stated: rsl-rl's default"
    ),
    Row(
        "observation normalisation",
        "obs_normalization",
        _yes_no,
        why_ppo_gail="rsl-rl's usual setting: the lidar's tags are rare one-hots and weigh like the "
        "distances once normalised; no trial against the study's value is recorded",
    ),
    Row("rollout per env and update (time_horizon)", "num_steps_per_env", why_ppo_gail=UNTESTED),
    Row("samples per update (buffer_size)", "buffer", why_ppo_gail=UNTESTED),
    Row(
        "parallel envs",
        "num_envs",
        why_ppo_gail="many short rollouts per update",
        why_study="not stated: 16 rollouts of 128 steps fill the study's buffer of 2048",
    ),
    Row("mini-batch (batch_size)", "mini_batch", why_ppo_gail=UNTESTED),
    Row("epochs per update", "num_learning_epochs"),
    Row("PPO learning rate (initial)", "learning_rate"),
    CodeRow("extrinsic reward strength", "1.0", "1.0", "1.0", source="Table 5.3"),
    CodeRow("recurrent network", "no", "no", "no", source="Table 5.2: use_recurrent"),
    Row(
        "schedule of learning rate, clip and entropy",
        "learning_rate_schedule",
        why_ppo_gail="a fixed rate; rsl-rl's adaptive one scored lower (docs/experiments.md, Learning-rate "
        "schedule). The linear decay was not tried",
    ),
    Row(
        "entropy coefficient (beta)",
        "entropy_coef",
        why_ppo_gail="with 0.01 the policy's std collapsed to 0.04 and it circled in place "
        "(docs/experiments.md, Entropy bonus)",
    ),
    Row("clip range (epsilon)", "clip_param"),
    Row("GAE lambda", "lam"),
    Row("discount (every reward signal)", "gamma"),
    Row(
        "lower clamp of the policy's std",
        "min_action_std",
        why_ppo_gail="the discriminator pushes the std down; the clamp keeps the policy exploring "
        "(docs/experiments.md, Action std)",
        why_study="not stated; ML-Agents does not clamp it",
    ),
    Row(
        "curiosity reward and model",
        "curiosity_form",
        CURIOSITY_FORMS.get,
        why_ppo_gail="the raw forward error scales with the learned features' drift; over its running std "
        "it is in units of typical surprise, so a strength means the same across envs and over training "
        "(reward_models.py)",
    ),
    Row("curiosity strength", "curiosity_strength"),
    Row("curiosity encoding size", "curiosity_encoding_size"),
    Row("curiosity learning rate", "curiosity_learning_rate"),
    Row(
        "GAIL strength",
        "gail_strength",
        why_ppo_gail="at 0.3 the policy imitated the expert's lidar view and ignored the coverage patch: "
        "0.53 of a320_cell, no full_cabin cell (docs/experiments.md, GAIL strength)",
    ),
    Row("GAIL discriminator hidden layers (encoding_size)", "gail_hidden_dims", _layers),
    Row(
        "GAIL reward and gradient penalty",
        "gail_form",
        GAIL_FORMS.get,
        why_ppo_gail="-log(1 - D) is positive, a bonus for every step, and episodes end on success: it pays "
        "the agent not to finish; the logit uncentred is mostly negative and pays it to end episodes early "
        "(docs/experiments.md, GAIL reward centring)",
    ),
    Row(
        "GAIL discriminator input",
        "gail_use_actions",
        lambda use_actions: "observation and action" if use_actions else "observation",
        why_ppo_gail="Ho & Ermon's D(s, a)",
    ),
    Row(
        "GAIL gradient penalty weight",
        "gail_gradient_penalty",
        why_ppo_gail="the R1 penalty on BCE logits, lower than the 5-10 of least-squares discriminators "
        "(docs/experiments.md)",
    ),
    Row("GAIL learning rate", "gail_learning_rate"),
    Row(
        "value estimates",
        "value_per_signal",
        lambda per_signal: (
            "a value head per reward signal" if per_signal else "one value of the summed reward"
        ),
        why_ppo_gail="rsl-rl's PPO has one critic; the centred GAIL reward needs no value of its own (below)",
    ),
    Row(
        "value after an episode ends at a bound or the exit",
        "value_per_signal",
        lambda per_signal: (
            "zero for the environment reward only; GAIL's and curiosity's go on"
            if per_signal
            else "zero, for every reward"
        ),
        why_ppo_gail="the episode is over; its GAIL reward is centred, so ending pays neither way",
    ),
    CodeRow(
        "initial weights of every network",
        "not stated",
        "torch's default (Kaiming uniform)",
        "torch's default (Kaiming uniform)",
        why_ppo_gail="rsl-rl's and torch's defaults",
        why_study="not stated; ML-Agents' TensorFlow trainers drew Glorot uniform weights, not reproduced",
    ),
    CodeRow(
        "an episode's last observation",
        "not stated",
        "not seen: no curiosity reward at the last step; V(s_t) bootstraps the values that go on",
        "not seen: no curiosity reward at the last step; V(s_t) bootstraps the values that go on",
        why_ppo_gail="the runner hands over the next episode's first observation, whose prediction error "
        "says nothing about the dynamics; rsl-rl bootstraps a time-out likewise",
        why_study="not stated; ML-Agents rewards curiosity at, and bootstraps the values from, the episode's "
        "last observation, which rsl-rl's runner does not hand over",
    ),
    Row(
        "training steps",
        "steps",
        _steps,
        why_ppo_gail="about 20 minutes on a 2-core CPU; the ablations share the budget (docs/experiments.md, "
        "Training budget and time)",
    ),
    CodeRow(
        "demonstrator",
        "a person at the keyboard: 4827 steps in all for cleaning, 944 for tracking",
        "the boustrophedon planner, its episodes varied (start pose, perturbed path)",
        "the boustrophedon planner, deterministic: its episodes repeat one trajectory",
        source="§4.3.4",
        why_ppo_gail=PLANNER_EXPERT,
        why_study=PLANNER_EXPERT,
    ),
    Row(
        "demonstration episodes per cell",
        "demo_episodes",
        why_ppo_gail="the planner's episodes are identical; more would add no data",
    ),
    Row(
        "demonstrations start at a random pose",
        "demo_random_start",
        _yes_no,
        why_ppo_gail="the layout's start, where the plan begins; the shipped policies learnt from these",
        why_study="not stated; a person starts each episode somewhere else",
    ),
    Row(
        "demonstrations' executed actions perturbed (std)",
        "demo_action_noise",
        why_ppo_gail="noisy demonstrations made the policies worse (docs/experiments.md)",
        why_study="not stated; a person drives unsteadily: the planner's path, perturbed, and its way back "
        "recorded (DART); the std is a guess",
    ),
    Row(
        "random start pose per episode",
        "random_start",
        _yes_no,
        why_ppo_gail="the policy must clean a cell from wherever it enters it (docs/experiments.md, Random "
        "start poses)",
        why_study="not stated: the layout's start, where the demonstrations start",
    ),
    CodeRow(
        "training statistics logged every",
        "20000 / 10000 steps",
        "update (2048 steps)",
        "update (4096 steps)",
        source="Table 5.2: summary_freq",
        why_ppo_gail="`metrics.csv` keeps a row per update; it changes what is logged, not what is learnt",
        why_study="`metrics.csv` keeps a row per update; it changes what is logged, not what is learnt",
    ),
    Row(
        "episode step limit",
        "max_steps",
        lambda steps: "the layout's (1500)" if steps is None else str(steps),
        why_ppo_gail="the benchmark's limit for the training cells",
        why_study="not stated: the benchmark's limit for the training cells",
    ),
    Row(
        "checkpoint exported",
        "export",
        {"last": "the last", "best": "the best on cabin-v1-val"}.get,
        why_ppo_gail=CHECKPOINT_PROTOCOL,
        why_study=f"{CHECKPOINT_PROTOCOL}; the tracking stage's episodes end at an exit "
        "cabin-v1-val's cells lack",
    ),
    CodeRow(
        "running the trained policy in a cabin",
        "cleaning and tracking alternate as each cell is cleaned",
        "cleaning and tracking alternate as each cell is cleaned",
        "the one network throughout",
        source="§4.3.2, Fig. 4.15; `ppo_gail_study` reads the cell's state from the env's info",
        why_ppo_gail="one network for both tasks",
    ),
]


def _joined(values: list[str]) -> str:
    return values[0] if len(set(values)) == 1 else " / ".join(values)


def table_rows(shipped_config: Path = SHIPPED_CONFIG) -> list[dict]:
    """Each row's setting, the three values and the reasons, checked: a reason where a value differs from the
    study's (or the study is silent), none where it does not; ``ppo_gail``'s from ``shipped_config``."""
    ppo_gail = config_settings(TrainConfig.from_dict(json.loads(shipped_config.read_text())))
    study_configs = [config_settings(study_config(stage)) for stage in STAGES]
    study = [study_settings(stage) for stage in STAGES]
    rows = []
    for row in ROWS:
        if isinstance(row, CodeRow):
            source = f" ({row.source})" if row.source else ""
            values = {
                "study": row.study + source,
                "ppo_gail_study": row.ppo_gail_study,
                "ppo_gail": row.ppo_gail,
            }
            stated = row.study != "not stated"
            differs = {
                name: not stated or values[name] != row.study for name in ("ppo_gail", "ppo_gail_study")
            }
        else:
            stated = all(values.get(row.key) is not None for values in study)
            ours_study = [row.show(values[row.key]) for values in study_configs]
            theirs = [row.show(values[row.key]) for values in study] if stated else None
            ours = row.show(ppo_gail[row.key])
            source = ""
            if row.key in STUDY:
                source = f" ({STUDY[row.key].source})"
            values = {
                "study": (_joined(theirs) + source) if stated else "not stated",
                "ppo_gail_study": _joined(ours_study),
                "ppo_gail": ours,
            }
            differs = {
                "ppo_gail": not stated or any(ours != value for value in theirs),
                "ppo_gail_study": not stated or ours_study != theirs,
            }
        for name, why in (("ppo_gail", row.why_ppo_gail), ("ppo_gail_study", row.why_study)):
            if differs[name] and not why:
                raise ValueError(
                    f"{row.setting}: {name} differs from the study ({values[name]}) without a reason"
                )
            if why and not differs[name]:
                raise ValueError(
                    f"{row.setting}: a reason for {name}, whose value is the study's ({values[name]})"
                )
        rows.append(
            {"setting": row.setting, **values, "why_ppo_gail": row.why_ppo_gail, "why_study": row.why_study}
        )
    return rows


def markdown(shipped_config: Path = SHIPPED_CONFIG) -> str:
    lines = [
        "# The learned baselines against the study",
        "",
        "Generated by `python -m cabinbench.baselines.ppo_gail.differences` from the configs: `ppo_gail` is "
        f"our tuned variant (its shipped policy's `{shipped_config}`), `ppo_gail_study` the study's "
        "configuration as written (`baselines/ppo_gail/study.py`), the study is Xia (2020), §4.3 and §5.2. "
        "Two values joined by / are the cleaning and the tracking network's. A value in **bold** differs "
        'from the study\'s; "not stated": the study does not give it.',
        "",
        "| setting | the study | `ppo_gail_study` | `ppo_gail` (ours) | why `ppo_gail` differs (or, where "
        "the study is silent, has this value) | why `ppo_gail_study` does |",
        "|---|---|---|---|---|---|",
    ]
    for row in table_rows(shipped_config):
        cells = [
            row["setting"],
            row["study"],
            f"**{row['ppo_gail_study']}**" if row["why_study"] else row["ppo_gail_study"],
            f"**{row['ppo_gail']}**" if row["why_ppo_gail"] else row["ppo_gail"],
            row["why_ppo_gail"],
            row["why_study"],
        ]
        lines.append("| " + " | ".join(cell.replace("|", "\\|") for cell in cells) + " |")
    return "\n".join(lines) + "\n"


@user_errors
def main(argv: list[str] | None = None) -> int:
    parser = ArgumentParser(
        prog="python -m cabinbench.baselines.ppo_gail.differences",
        description="Write the table of differences between ppo_gail, ppo_gail_study and the study.",
    )
    parser.add_argument(
        "--out",
        type=output_file(".md"),
        default=DEFAULT_OUT,
        help=f"the Markdown file (default {DEFAULT_OUT})",
    )
    parser.add_argument(
        "--shipped-config",
        type=Path,
        default=SHIPPED_CONFIG,
        help=f"the shipped ppo_gail's training config.json (default {SHIPPED_CONFIG})",
    )
    args = parser.parse_args(argv)
    if not args.shipped_config.is_file():
        parser.error(
            f"argument --shipped-config: no file {args.shipped_config}; run from the repository root or give "
            "the config.json the shipped ppo_gail was trained with"
        )
    args.out.write_text(markdown(args.shipped_config))
    print(args.out)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
