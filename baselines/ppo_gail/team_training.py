"""Training ``ppo_gail_team``: one PPO + ICM + GAIL policy shared by every robot of a team.

The single-robot trainer (``baselines.ppo_gail.training``) runs unchanged: ``TeamTrainConfig`` is its
``TrainConfig`` with the team's envs and critic, and ``train``, ``export_latest``, checkpoints,
``--resume``, metrics and validation are the same functions. What differs:

- the envs: ``cabinbench.envs.batched_team.BatchedTeamEnv``, ``num_envs`` team envs of ``n_agents`` robots,
  every robot a row of rsl-rl's batch (so ``metrics.csv`` counts robot steps and robot episodes, K per team
  episode). Each robot acts on its own observation (decentralised execution); its reward is the team env's
  (own and team coverage, shared cell bonus; see that module);
- the critic: with ``centralised_critic`` it also sees the team env's PettingZoo ``state()`` and the robot's
  index (MAPPO's centralised training); the actor never does, so the exported policy runs on any robot's
  observation;
- the demonstrations: the team boustrophedon, every robot's (observation, action) pairs
  (``record_demonstrations(..., n_agents=K)``);
- the start: with ``init_policy`` the actor (weights, observation normaliser, action std) starts from a
  single-robot policy file, by default the shipped ``ppo_gail``; the critic, ICM and discriminator start
  fresh. The policy then only has to learn what a team adds (other robots in its lidar, floor cleaned by
  them) on the few iterations a 2-core CPU affords;
- validation plays the team (``n_agents`` robots) on layouts of cabin-v1-val, as a single robot's does.

The shipped policy takes two such runs (``scripts/train_team_policies.sh``): K = 2 from ``ppo_gail``, then
K = 4 from that policy with ``--init-policy`` and no entropy bonus (``docs/experiments.md``, "The learned
team").

``python -m cabinbench.train --baseline ppo_gail_team --layout full_cabin --agents 2`` runs it
(``baselines.ppo_gail.cli``); ``python -m cabinbench.run --baseline ppo_gail_team --agents 2`` plays the
exported policy (``policy.PPOGailTeam``).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

import torch
from cabinbench.baselines.ppo_gail.options import option
from cabinbench.baselines.ppo_gail.training.config import TrainConfig

TEAM_POLICY = "ppo_gail_team"


@dataclass
class TeamTrainConfig(TrainConfig):
    """``TrainConfig`` for a team; the fields below are new or have another default. How its first runs
    went (and the centralised critic against a local one): ``docs/experiments.md``, "The learned team"."""

    layouts: list[str] = field(default_factory=lambda: ["full_cabin"])
    """Training layouts, round-robin over the team envs: the whole cabin, where teams are scored."""
    n_agents: int = option(2, flag="--agents", metavar="K")
    """Robots per team env (K)."""
    num_envs: int = 8
    """Team envs; rsl-rl's batch has ``num_envs * n_agents`` rows (16 robots with the defaults)."""
    num_steps_per_env: int = 128
    """Rollout length per robot and iteration: 16 x 128 = 2048 robot steps an iteration, half the
    single-robot trainer's, as a team step costs K robot steps of the env."""
    num_mini_batches: int = 2
    """Mini-batches per epoch: 1024 samples each, as the single-robot trainer's."""
    max_steps: int | None = 6000
    """Episode step limit: 600 s, the makespan target on ``full_cabin`` with K = 2 (the layout's own limit
    is 1500 s); longer episodes would spend the few iterations on the cabin's last cells."""
    validation_episodes: int = 5
    """Layouts of cabin-v1-val on each of which a validated checkpoint's team plays one episode: ``n_agents``
    robots, as the team is scored, from random starts, each episode stopped at ``max_steps`` (so its
    clean_score's time limit is 600 s on every layout). Fewer than a single robot's 10: a team episode cost
    2.7 CPU-s (4 K = 2 episodes, 16 k team steps: 10.8 CPU-s) against 1.65 CPU-s a K = 2 iteration, so 5
    every ``validation_interval`` = 100 iterations cost about 8 % of the training (docs/experiments.md, "What
    validation costs"). Runs before cabin-v1-val played 2 team episodes on each training layout."""
    validation_interval: int = 100
    """Validate every 100 iterations' checkpoint (and the last): team runs are a few hundred iterations."""
    centralised_critic: bool = option(True)
    """The critic also sees the team env's ``state()`` and the robot's index (MAPPO); False: it sees what the
    actor sees (independent PPO with a shared policy)."""
    team_weight: float = option(0.5)
    """Weight of the team's new area in each robot's ``coverage`` reward (the team env's default)."""
    init_policy: str = option("ppo_gail", metavar="FILE|NAME")
    """A policy file, or the name of a shipped one (``baselines/ppo_gail/checkpoints/<name>.pt``), whose
    actor the team policy starts from; "" starts from random weights."""

    def __post_init__(self) -> None:
        super().__post_init__()
        if self.ablation != "ppo_gail":
            raise ValueError(f"{TEAM_POLICY} trains the ppo_gail ablation only, not {self.ablation!r}")
        if self.n_agents < 1:
            raise ValueError(f"n_agents must be positive, got {self.n_agents}")
        if self.init_policy:
            from cabinbench.baselines.ppo_gail.policy import read_policy_file

            read_policy_file(initial_policy_path(self.init_policy))  # a bad file: one line, before any work

    @property
    def policy_name(self) -> str:
        return TEAM_POLICY

    @property
    def episode_options(self) -> dict:
        return {"n_agents": self.n_agents}

    @property
    def obs_groups(self) -> dict:
        critic = ["policy", "state"] if self.centralised_critic else ["policy"]
        return {"actor": ["policy"], "critic": critic}

    @property
    def env_kwargs(self) -> dict:
        """Keyword arguments of the team envs (``BatchedTeamEnv``, and the demonstrations' team env)."""
        return {
            "n_agents": self.n_agents,
            "reward": self.reward,
            "max_steps": self.max_steps,
            "random_start": self.random_start,
            "coverage_patch": self.coverage_patch,
            "coverage_patch_cell": self.coverage_patch_cell,
            "team_weight": self.team_weight,
        }

    def make_env(self):
        from cabinbench.envs.batched_team import BatchedTeamEnv, RslRlTeamVecEnv

        batched = BatchedTeamEnv(self.layouts, self.num_envs, seed=self.first_env_seed, **self.env_kwargs)
        return RslRlTeamVecEnv(batched), batched.observation_config, batched.observation_layout

    def initialise(self, runner) -> None:
        """Start the actor from ``init_policy`` (see the field)."""
        if self.init_policy:
            start_actor_from(runner, initial_policy_path(self.init_policy))


def initial_policy_path(init_policy: str) -> Path:
    """The policy file ``init_policy`` names: a path, or a shipped policy's name."""
    from cabinbench.baselines.ppo_gail.policy import CHECKPOINT_DIR

    path = Path(init_policy)
    return path if path.suffix == ".pt" else CHECKPOINT_DIR / f"{init_policy}.pt"


def start_actor_from(runner, path: Path) -> None:
    """Load a policy file's actor into the runner's: MLP weights, observation normaliser (its statistics
    weighted by the steps they were gathered over, so the first rollout does not replace them) and action
    std."""
    from cabinbench.baselines.ppo_gail.policy import PolicyFileError, read_policy_file

    policy = read_policy_file(path)
    actor = runner.alg.get_policy()
    if policy["actor"]["observation_size"] != actor.obs_dim:
        raise PolicyFileError(
            f"{path}: its actor takes {policy['actor']['observation_size']} observation entries, the team "
            f"env gives {actor.obs_dim}; train with the observation settings it was trained with"
        )
    with torch.no_grad():
        actor.mlp.load_state_dict(policy["actor"]["state_dict"])
        normalizer = policy["obs_normalizer"]
        if normalizer is not None and actor.obs_normalization:
            actor.obs_normalizer._mean.copy_(normalizer["mean"].reshape(1, -1))
            actor.obs_normalizer._std.copy_(normalizer["std"].reshape(1, -1))
            actor.obs_normalizer._var.copy_(normalizer["std"].reshape(1, -1).square())
            actor.obs_normalizer.count.fill_(int(policy["training"].get("timesteps") or 1))
        distribution = actor.distribution
        if getattr(distribution, "std_type", "scalar") == "log":
            distribution.log_std_param.copy_(policy["action_std"].log())
        else:
            distribution.std_param.copy_(policy["action_std"])
