"""One observation-normaliser update for an actor and a critic that normalise alike.

rsl-rl's PPO update ends by updating the actor's and then the critic's running observation statistics
on the whole rollout (``MLPModel.update_normalization``): the same mean and variance of the same
observations, computed twice when both models see the same observation groups. Their normalisers then
hold the same numbers, and after the actor's update the critic's may take the actor's result instead of
computing it again: the same numbers, bit for bit.
"""

from __future__ import annotations

import torch
from rsl_rl.models import MLPModel


def update_normalisers_once(actor: MLPModel, critic: MLPModel) -> None:
    """Make the critic's ``update_normalization`` copy the actor's new statistics when it is called, as
    PPO calls it, right after the actor's on the same observations and while the two normalisers held
    the same statistics before (else it updates its own, as before); nothing where the models see other
    observation groups, either does not normalise, or they update or normalise in other ways."""
    alike = (
        actor.obs_normalization
        and critic.obs_normalization
        and actor.obs_groups == critic.obs_groups
        and type(actor).update_normalization is type(critic).update_normalization
        and type(actor.obs_normalizer) is type(critic.obs_normalizer)
    )
    if not alike:
        return
    update_actor, update_critic = actor.update_normalization, critic.update_normalization
    before: dict = {}  # the observations of the actor's last update, and its statistics before it

    def actor_update(obs) -> None:
        before.update(obs=obs, statistics=_statistics(actor, clone=True))
        update_actor(obs)

    def critic_update(obs) -> None:
        alike = (
            before.pop("obs", None) is obs
            and actor.obs_normalizer.until == critic.obs_normalizer.until
            and actor.obs_normalizer.training == critic.obs_normalizer.training
            and all(
                torch.equal(mine, theirs)
                for mine, theirs in zip(_statistics(critic), before.pop("statistics"), strict=True)
            )
        )
        before.clear()
        if not alike:
            update_critic(obs)
            return
        for mine, theirs in zip(_statistics(critic), _statistics(actor), strict=True):
            mine.copy_(theirs)

    actor.update_normalization, critic.update_normalization = actor_update, critic_update


def _statistics(model: MLPModel, clone: bool = False) -> list[torch.Tensor]:
    """The normaliser's buffers (mean, variance, std, count), in their order."""
    return [buffer.clone() if clone else buffer for _, buffer in sorted(model.obs_normalizer.named_buffers())]
