"""The ``bc`` and ``dagger`` baselines: the policy file a ``bc``/``dagger`` training exported
(``baselines.imitation.training``; the format of ``baselines.ppo_gail.policy``), played with its mean action
(``stochastic=True`` adds the residual std of the regression as Gaussian noise)."""

from __future__ import annotations

import os

from cabinbench.baselines.ppo_gail.policy import LearnedPolicy


class ImitationPolicy(LearnedPolicy):
    """A policy learned by imitating the boustrophedon expert. Config: ``checkpoint`` (a policy file; default
    ``baselines/ppo_gail/checkpoints/<name>.pt``) and ``stochastic`` (default False: the mean action)."""

    trainer = "cabinbench.baselines.ppo_gail.cli:main"

    def __init__(self, checkpoint: str | os.PathLike | None = None, stochastic: bool = False) -> None:
        super().__init__(checkpoint, stochastic)


class BehaviourCloning(ImitationPolicy):
    """Behaviour cloning: regression on the expert's actions along the expert's own episodes."""

    name = ablation = "bc"


class DAgger(ImitationPolicy):
    """DAgger (Ross et al. 2011): regression on the expert's actions at the states the learned policy
    visits, round after round (``baselines.imitation.expert`` says how the expert is asked)."""

    name = ablation = "dagger"
