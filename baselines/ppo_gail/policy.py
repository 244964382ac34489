"""The learned baselines ppo_gail, ppo, ppo_icm, ppo_gail_only, ppo_gail_team and ppo_gail_study: their
shipped policies, in plain torch (``ppo_gail_study`` runs a pair of them, see ``PPOGailStudy``).

Each baseline loads its policy file (default ``baselines/ppo_gail/checkpoints/<ablation>.pt``, or
``checkpoint=`` in its config, e.g. ``--config '{"checkpoint": "runs/train/ppo_gail__seed0/policy.pt"}'``)
once, checks that it was trained on observations shaped like the env's, and samples its actions from the
trained Gaussian policy (mean + action_std * noise, clipped to [-1, 1]), with a generator seeded by the
episode seed and the robot's index, so episodes stay reproducible. Sampling is the default, as in ML-Agents'
inference that the study used: a memoryless policy acting deterministically in a deterministic env can loop
forever in the same place (docs/experiments.md, "Sampled or mean actions"). ``stochastic=False`` takes the
mean action.

A policy file is small (a few hundred KB) and loads with ``torch.load(path, weights_only=True)``: a dict of
plain values and tensors, written by ``export_policy`` at the end of training
(``baselines.ppo_gail.training``)::

    format              "cabinbench-policy/1"
    ablation            the baseline: "ppo_gail" | "ppo" | "ppo_icm" | "ppo_gail_only" | "ppo_gail_team" |
                        "ppo_lstm" | "bc" | "dagger" (``baselines.imitation``)
    actor               {"hidden_dims": [64, 64], "activation": "elu", "observation_size": D,
                         "action_size": 2,
                         "state_dict": the MLP's weights, rsl-rl's key names ("0.weight", "0.bias", ...)}
    obs_normalizer      {"mean": [D], "std": [D], "eps": float} or None (rsl-rl's EmpiricalNormalization)
    action_std          [A], the Gaussian policy's std at the end of training (used only with ``stochastic``)
    observation_config  the observation settings the policy was trained with, and D
                        (``CoverageEnv.observation_config``); ``run`` makes the env with them
                        (``env_options``)
    env_config          the training envs' layouts, reward preset, terminate_on_bound, max_steps (a team's:
                        n_agents, team_weight)
    training            the training summary: iterations, steps, time, final coverage and success ...
    memory              only a recurrent actor's (``ppo_lstm``): its normaliser and RNN, which feed ``actor``
                        (``baselines.ppo_gail.memory``; ``obs_normalizer`` is then None)
    inference           the precision the policy acts in (``networks.Inference``): "float64" in every file
                        written now; absent, "float32": the files written before it, every shipped one among
                        them, play as they did when the committed records were played

The actor is rebuilt from its saved architecture in plain torch (``baselines.ppo_gail.networks``, no rsl-rl
import), and reproduces rsl-rl's inference policy exactly (tested). The baselines act with its
``Inference``. Computed in float64 (from the float32 weights) and rounded to float32, the mean action of a
file's ONNX twin (``baselines.onnx``) is the torch policy's, bit for bit, and ``run`` scores the two alike;
computed in float32, the two differ by ~1e-7, which physics amplifies into other episodes.
"""

from __future__ import annotations

import contextlib
import math
import os
import pickle
from collections.abc import Iterator
from pathlib import Path

import numpy as np
import torch
import torch.nn as nn
from cabinbench.baselines.ppo_gail.memory import memory_entry
from cabinbench.baselines.ppo_gail.networks import PRECISIONS, Actor, Inference

from cabinbench.agents import Baseline, EpisodeContext, exact_action

FORMAT = "cabinbench-policy/1"
WRITTEN_PRECISION = "float64"  # the ``inference`` of every file written now
CHECKPOINT_DIR = Path(__file__).resolve().parent / "checkpoints"


class PolicyFileError(ValueError):
    """A policy file is missing, unreadable, malformed, or does not fit the env."""


# ----------------------------------------------------------------------------------------------------
# Export (called by training) and loading
# ----------------------------------------------------------------------------------------------------


def export_policy(
    runner,
    path: str | os.PathLike,
    *,
    ablation: str,
    observation_config: dict,
    env_config: dict,
    training: dict,
) -> Path:
    """Write the policy file of an rsl-rl ``OnPolicyRunner``'s actor (atomically). Returns the path. A
    recurrent actor's normaliser goes with its RNN, under ``memory`` (``baselines.ppo_gail.memory``)."""
    model = runner.alg.get_policy()
    normalizer = None
    if model.obs_normalization:
        stats = model.obs_normalizer
        normalizer = {
            "mean": stats.mean.detach().cpu().clone(),
            "std": stats.std.detach().cpu().clone(),
            "eps": float(stats.eps),
        }
    memory = {"memory": memory_entry(model, normalizer)} if model.is_recurrent else {}
    return write_policy_file(
        path,
        model.mlp,
        runner.cfg["actor"].get("activation", "elu"),
        ablation=ablation,
        obs_normalizer=None if memory else normalizer,
        action_std=_action_std(model),
        observation_config=observation_config,
        env_config=env_config,
        training=training,
        **memory,
    )


def write_policy_file(path: str | os.PathLike, network: nn.Sequential, activation: str, **entries) -> Path:
    """Write the policy file of the MLP ``network`` (Linear, activation, ..., Linear) atomically, with the
    further ``entries`` of the format (``ablation``, ``obs_normalizer`` ...); the policy acts in float64
    (``inference``). Returns the path."""
    linear_layers = [module for module in network if isinstance(module, nn.Linear)]
    actor = {
        "hidden_dims": [layer.out_features for layer in linear_layers[:-1]],
        "activation": activation,
        "observation_size": int(linear_layers[0].in_features),
        "action_size": int(linear_layers[-1].out_features),
        "state_dict": {key: value.detach().cpu().clone() for key, value in network.state_dict().items()},
    }
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    atomic_torch_save(
        {"format": FORMAT, "inference": WRITTEN_PRECISION, "actor": actor, **_plain(entries)}, path
    )
    return path


def write_in_float64(path: str | os.PathLike, target: str | os.PathLike | None = None) -> Path:
    """Write the policy file ``path`` (or a copy of it at ``target``) to act in float64, as every file written
    now does: the same network, computed in float64 and its mean action rounded to float32, so that its ONNX
    twin acts alike to the bit. Its episodes change, so the records played with it must be played again.
    Returns the path written."""
    read_policy_file(path)  # a bad file is a PolicyFileError before anything is written
    target = Path(path if target is None else target)
    atomic_torch_save({**torch.load(path, weights_only=True), "inference": WRITTEN_PRECISION}, target)
    return target


def atomic_torch_save(obj, path: Path) -> None:
    """Write ``obj`` to ``path`` via a temporary file and ``os.replace``: a reader (or an interruption) never
    sees a half-written file."""
    temporary = path.with_name(path.name + ".tmp")
    try:
        torch.save(obj, temporary)
        os.replace(temporary, path)
    finally:
        temporary.unlink(missing_ok=True)


def _action_std(model) -> torch.Tensor:
    """The std of rsl-rl's Gaussian head, clamped to its range as the distribution does."""
    distribution = model.distribution
    low, high = distribution.std_range
    if getattr(distribution, "std_type", "scalar") == "log":
        return distribution.log_std_param.detach().exp().clamp(low, high).cpu().clone()
    return distribution.std_param.detach().clamp(low, high).cpu().clone()


def read_policy_file(path: str | os.PathLike) -> dict:
    """Load and validate a policy file; every problem raises ``PolicyFileError`` naming the file."""
    path = Path(path)
    if not path.is_file():
        raise PolicyFileError(
            f"{path}: policy file not found. Train and ship one with "
            f"`python -m cabinbench.train --baseline <name> --ship`, or pass "
            f'--config \'{{"checkpoint": "runs/train/<run>/policy.pt"}}\'.'
        )
    try:
        data = torch.load(path, weights_only=True, map_location="cpu")
    except pickle.UnpicklingError:  # torch's refusal spans many lines and suggests weights_only=False
        raise PolicyFileError(
            f"{path}: cannot read the policy file: it holds more than tensors and plain values, which "
            "torch.load(weights_only=True) refuses. It may be corrupted or not a policy file."
        ) from None
    except Exception as error:  # torch raises a variety of types for truncated or foreign files
        reason = next(iter(str(error).splitlines()), "")
        raise PolicyFileError(
            f"{path}: cannot read the policy file ({type(error).__name__}: {reason}). "
            "It may be corrupted or not a torch file."
        ) from None
    if not isinstance(data, dict) or data.get("format") != FORMAT:
        hint = ""
        if isinstance(data, dict) and "actor_state_dict" in data:
            hint = (
                " It looks like a full rsl-rl training checkpoint; training exports the shippable policy as "
                "policy.pt next to checkpoints/."
            )
        raise PolicyFileError(f"{path}: not a cabinbench policy file (expected format {FORMAT!r}).{hint}")
    data["inference"] = data.get("inference", "float32")
    if not isinstance(data["inference"], str) or data["inference"] not in PRECISIONS:
        raise PolicyFileError(
            f"{path}: inference {data['inference']!r} is not 'float32' or 'float64'; export the policy again "
            "(train --export-latest writes float64), or remove the entry (float32, as in older files)."
        )
    try:
        actor = data["actor"]
        network = Actor(
            actor["observation_size"],
            actor["action_size"],
            actor["hidden_dims"],
            actor["activation"],
            data["obs_normalizer"],
        )
        network.mlp.load_state_dict(actor["state_dict"], strict=True)
        data["action_std"] = torch.as_tensor(data["action_std"], dtype=torch.float32).reshape(
            actor["action_size"]
        )
        for key in ("ablation", "observation_config"):
            data[key]  # noqa: B018 - presence check
        network.eval()
        data["network"] = network
        data["inference_model"] = Inference(data).eval()
    except (KeyError, TypeError, ValueError, RuntimeError) as error:
        raise PolicyFileError(f"{path}: malformed policy file ({type(error).__name__}: {error}).") from None
    return data


_CACHE: dict[tuple[str, int, int], dict] = {}


def load_policy(path: str | os.PathLike) -> dict:
    """``read_policy_file``, cached per file (path, modification time and size)."""
    path = Path(path).resolve()
    stat = path.stat() if path.is_file() else None
    key = (str(path), stat.st_mtime_ns if stat else 0, stat.st_size if stat else 0)
    if key not in _CACHE:
        _CACHE[key] = read_policy_file(path)
    return _CACHE[key]


def check_observation_config(trained: dict, env: dict, path: str | os.PathLike) -> None:
    """Raise ``PolicyFileError`` unless the env's observation is shaped like the policy's training
    observation."""
    different = [key for key in sorted(set(trained) | set(env)) if not _same(trained.get(key), env.get(key))]
    if different:
        details = ", ".join(f"{key}: trained {trained.get(key)!r}, env {env.get(key)!r}" for key in different)
        raise PolicyFileError(
            f"{path}: the policy was trained on another observation layout ({details}). "
            "Run the env with the observation settings the policy was trained with (its "
            "env_options), or retrain."
        )


# ----------------------------------------------------------------------------------------------------
# The baselines
# ----------------------------------------------------------------------------------------------------


class LearnedPolicy(Baseline):
    """A shipped rsl-rl policy. Config: ``checkpoint`` (path to a policy file; default the shipped one) and
    ``stochastic`` (sample actions from the trained Gaussian policy; default True; False takes its mean)."""

    name = "learned_policy"
    trainer = "cabinbench.baselines.ppo_gail.cli:main"
    config_files = ("checkpoint",)
    ablation = ""

    @staticmethod
    def training_layouts(configs: list[dict], size: int) -> tuple[list[str], int]:
        """The first ``size`` layouts every run of ``configs`` (``config.json`` contents) trained on, and how
        many envs the runs seeded alike (``training.suite_draws``); reachable through the registry by the
        leaderboard's generalisation gap, which may not import a baseline."""
        from cabinbench.baselines.ppo_gail.training.suite_draws import shared_envs, training_sample

        return training_sample(configs, size), shared_envs(configs)

    def __init__(
        self, checkpoint: str | os.PathLike | None = None, stochastic: bool = True, **config
    ) -> None:
        if config:
            raise TypeError(f"{self.name} takes only `checkpoint` and `stochastic`, not {sorted(config)}")
        if not isinstance(stochastic, bool):  # bool("no") is True
            raise ValueError(f"stochastic must be true or false, got {stochastic!r}")
        settings = {"checkpoint": str(checkpoint)} if checkpoint is not None else {}
        super().__init__(**settings, stochastic=stochastic)
        self.path = Path(checkpoint) if checkpoint is not None else CHECKPOINT_DIR / f"{self.name}.pt"
        self.stochastic = stochastic
        self.policy = load_policy(self.path)
        if self.policy["ablation"] != self.ablation:
            raise PolicyFileError(
                f"{self.path}: holds a {self.policy['ablation']!r} policy, not {self.ablation!r}; "
                f"run it as --baseline {self.policy['ablation']}"
            )
        self.inference: Inference = self.policy["inference_model"]
        self.state: tuple[torch.Tensor, ...] = ()
        self.rng: np.random.Generator | None = None

    @property
    def env_options(self) -> dict:
        """The observation settings the policy was trained with."""
        return {key: value for key, value in self.policy["observation_config"].items() if key != "size"}

    def reset(self, context: EpisodeContext, observation: np.ndarray, info: dict) -> None:
        from cabinbench.envs.coverage_env import observation_config

        super().reset(context, observation, info)
        env_config = observation_config(context.env_config, np.asarray(observation).shape[-1])
        check_observation_config(self.policy["observation_config"], env_config, self.path)
        self.state = self.inference.initial_state()
        if self.stochastic:
            self.rng = np.random.default_rng([context.seed, context.agent])
            self.action_std = self.policy["action_std"].numpy().astype(np.float64)

    def act(self, observation: np.ndarray, info: dict) -> np.ndarray:
        observation = torch.as_tensor(observation, dtype=self.inference.dtype).reshape(1, -1)
        with torch.no_grad(), one_torch_thread():
            mean, *state = self.inference(observation, *self.state)
        self.state = tuple(state)
        action = mean[0].numpy().astype(np.float64)
        if self.stochastic:
            action = action + self.action_std * self.rng.standard_normal(action.shape)
        return np.clip(action, -1.0, 1.0)


class PPOGail(LearnedPolicy):
    """PPO + curiosity (ICM) + GAIL: our tuned variant of the study's learner (one network, dense reward,
    coverage patch; ``ppo_gail_study`` is the study's configuration, ``results/differences.md`` the
    differences)."""

    name = ablation = "ppo_gail"


class PPOGailSuite(PPOGail):
    """Our ppo_gail trained on the suite ``cabin-v1-train`` through ``CabinBench/Suite-v0`` (a new layout at
    every reset) instead of on the study's two cells: ``python -m cabinbench.train --baseline ppo_gail
    --suite cabin-v1-train`` (``scripts/train_suite_policies.sh``). Its policy files record the suite they
    trained on."""

    name = "ppo_gail_suite"

    def __init__(self, checkpoint: str | os.PathLike | None = None, stochastic: bool = True) -> None:
        super().__init__(checkpoint, stochastic)
        if not self.policy.get("env_config", {}).get("suite"):
            raise PolicyFileError(
                f"{self.path}: trained on layouts {self.policy.get('env_config', {}).get('layouts')}, "
                "not on a suite; run it as --baseline ppo_gail"
            )


class PPO(LearnedPolicy):
    """Ablation: PPO on the environment reward alone."""

    name = ablation = "ppo"


class PPOCuriosity(LearnedPolicy):
    """Ablation: PPO + curiosity (ICM), no imitation."""

    name = ablation = "ppo_icm"


class PPOGailOnly(LearnedPolicy):
    """Ablation: PPO + GAIL, no curiosity."""

    name = ablation = "ppo_gail_only"


class PPOGailTeam(LearnedPolicy):
    """PPO + curiosity (ICM) + GAIL trained in teams (ours; ``baselines.ppo_gail.team_training``): one policy
    shared by every robot, each acting on its own observation. Its file's ``env_config["n_agents"]`` is the
    team size it was trained with; it runs with any K (``--agents``), and on a single robot."""

    name = ablation = "ppo_gail_team"


class PPOGailStudy(Baseline):
    """The study's learner run as the study runs it (§4.3.2, Fig. 4.15): two networks of the study's
    configuration (``baselines.ppo_gail.study``), one that cleans a cell and one that tracks to the next
    cell's exit, taking turns as the sequential protocol moves on. Config: ``cleaning`` and ``tracking``
    (policy files; default the shipped ``ppo_gail_study_cleaning.pt`` and ``ppo_gail_study_tracking.pt``)
    and ``stochastic`` (as ``LearnedPolicy``).

    Which network acts is read from the env's ``info`` and the layout, as the study's process controller
    knows it (it removes the bound and shows the exit when the cell's last white cube is reached, Fig.
    4.15), never from the observation: while the current cell is clean (``layout.cleared_cells`` +
    ``info["cells_cleared"]`` cells are clean, counted from the first, and ``info["current_cell"]`` is
    among them) the tracking network acts, else the cleaning one. In the ``open`` protocol there are no
    exits to track: the cleaning network acts throughout."""

    name = "ppo_gail_study"
    trainer = "cabinbench.baselines.ppo_gail.cli:main"
    config_files = ("cleaning", "tracking")

    def __init__(
        self,
        cleaning: str | os.PathLike | None = None,
        tracking: str | os.PathLike | None = None,
        stochastic: bool = True,
    ) -> None:
        settings = {
            key: str(value) for key, value in (("cleaning", cleaning), ("tracking", tracking)) if value
        }
        super().__init__(**settings, stochastic=stochastic)
        self.networks = {
            stage: PPOGail(path or CHECKPOINT_DIR / f"{self.name}_{stage}.pt", stochastic)
            for stage, path in (("cleaning", cleaning), ("tracking", tracking))
        }
        cleaning_config, tracking_config = (network.env_options for network in self.networks.values())
        if cleaning_config != tracking_config:
            raise PolicyFileError(
                f"{self.networks['tracking'].path}: trained on another observation than "
                f"{self.networks['cleaning'].path} ({tracking_config} vs {cleaning_config}); "
                "the pair must share one"
            )
        self.stage = "cleaning"

    @property
    def env_options(self) -> dict:
        return self.networks["cleaning"].env_options

    def reset(self, context: EpisodeContext, observation: np.ndarray, info: dict) -> None:
        super().reset(context, observation, info)
        for network in self.networks.values():
            network.reset(context, observation, info)
        self.networks["tracking"].rng = self.networks["cleaning"].rng  # one noise stream for the episode

    def act(self, observation: np.ndarray, info: dict) -> np.ndarray:
        self.stage = tracking_or_cleaning(self.context, info)
        return exact_action(self.networks[self.stage], observation, info)  # this act casts it to float32


@contextlib.contextmanager
def one_torch_thread() -> Iterator[None]:
    """torch on one thread inside, the process's own setting again after. For one observation at a time:
    torch's intra-op threads only add overhead, and on a busy 2-core machine they turned a 0.3 ms forward
    pass into 14 ms."""
    threads = torch.get_num_threads()
    if threads == 1:
        yield
        return
    torch.set_num_threads(1)
    try:
        yield
    finally:
        torch.set_num_threads(threads)


def tracking_or_cleaning(context: EpisodeContext, info: dict) -> str:
    """ "tracking" while the robot's current cell is clean (its exit shows), else "cleaning"."""
    clean_cells = context.layout.cleared_cells + info["cells_cleared"]
    if context.protocol == "sequential" and clean_cells > info["current_cell"]:
        return "tracking"
    return "cleaning"


# ----------------------------------------------------------------------------------------------------


def _plain(value):
    """JSON-like plain values (what ``weights_only`` loading accepts): dicts, lists, str, int, float, bool,
    None."""
    if isinstance(value, dict):
        return {str(key): _plain(item) for key, item in value.items()}
    if isinstance(value, (list, tuple)):
        return [_plain(item) for item in value]
    if isinstance(value, (np.generic,)):
        return value.item()
    if isinstance(value, Path):
        return str(value)
    return value


def _same(a, b) -> bool:
    if isinstance(a, float) or isinstance(b, float):
        return (
            a is not None and b is not None and math.isclose(float(a), float(b), rel_tol=1e-9, abs_tol=1e-12)
        )
    return a == b
