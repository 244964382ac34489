"""ML-Agents' curiosity and GAIL reward signals (``baselines/ppo_gail/mlagents.py``) on small hand-made
batches, against values computed by hand."""

from __future__ import annotations

import math

import pytest
import torch
from cabinbench.baselines.ppo_gail.mlagents import MlAgentsCuriosity, MlAgentsDiscriminator


def constant_discriminator(estimate: float, use_actions: bool = False) -> MlAgentsDiscriminator:
    """A trained discriminator of 2-d observations and 1-d actions whose D is ``estimate`` everywhere."""
    discriminator = MlAgentsDiscriminator(2, 1, [4], use_actions=use_actions)
    output = discriminator.network[-1]
    with torch.no_grad():
        output.weight.zero_()
        output.bias.fill_(math.log(estimate / (1.0 - estimate)))
    discriminator.has_updated.fill_(True)
    return discriminator


@pytest.mark.parametrize(
    ("estimate", "reward"),
    # -ln(1 - D + 1e-7), by hand
    [(0.5, 0.6931470), (0.9, 2.3025841), (0.1, 0.1053604)],
)
def test_gail_reward_is_minus_log_of_one_minus_d(estimate, reward):
    discriminator = constant_discriminator(estimate)
    states, actions = torch.zeros(3, 2), torch.zeros(3, 1)
    assert discriminator.reward(states, actions).tolist() == pytest.approx([reward] * 3, rel=1e-5)


def test_gail_pays_nothing_before_its_first_update():
    discriminator = constant_discriminator(0.9)
    discriminator.has_updated.fill_(False)
    assert discriminator.reward(torch.zeros(2, 2), torch.zeros(2, 1)).tolist() == [0.0, 0.0]


def test_gail_discriminator_sees_the_observation_only_unless_use_actions():
    torch.manual_seed(0)
    states, actions = torch.randn(16, 2), torch.rand(16, 1) * 2 - 1
    other_actions = -actions
    other_states = states + 0.5

    blind = MlAgentsDiscriminator(2, 1, [8, 8])
    blind.has_updated.fill_(True)
    assert torch.equal(blind.reward(states, actions), blind.reward(states, other_actions))
    assert not torch.allclose(blind.reward(states, actions), blind.reward(other_states, actions))

    seeing = MlAgentsDiscriminator(2, 1, [8, 8], use_actions=True)
    seeing.has_updated.fill_(True)
    assert not torch.allclose(seeing.reward(states, actions), seeing.reward(states, other_actions))


def test_gradient_penalty_of_a_linear_discriminator_at_the_interpolated_samples():
    """D(x) = sigmoid(3 x_1 + 4 x_2): at a point where the logit is 0, ||grad D|| = 0.25 * 5 = 1.25 and the
    penalty (1.25 - 1)^2 = 0.0625. Both rows mix to (0, 0) only when the noise weighs the expert."""
    discriminator = MlAgentsDiscriminator(2, 1, [4])
    discriminator.network = torch.nn.Linear(2, 1)
    with torch.no_grad():
        discriminator.network.weight.copy_(torch.tensor([[3.0, 4.0]]))
        discriminator.network.bias.zero_()
    agent = torch.tensor([[1.0, 0.0], [1.0, 0.0]])
    expert = torch.tensor([[-1.0, 0.0], [0.0, 0.0]])
    noise = torch.tensor([[0.5, 0.5], [1.0, 0.2]])  # x_hat = noise * expert + (1 - noise) * agent = (0, 0)
    penalty = discriminator.gradient_penalty(agent, expert, noise)
    assert penalty.item() == pytest.approx(0.0625, rel=1e-5)
    # The other way round the second row is (1, 0): logit 3, ||grad|| = 5 sigmoid'(3) = 0.2259, so a mean of
    # (0.0625 + 0.5993) / 2.
    swapped = discriminator.gradient_penalty(expert, agent, noise)
    assert swapped.item() == pytest.approx((0.0625 + 0.5992564) / 2, rel=1e-5)


def test_discriminator_loss_is_the_cross_entropy_of_both_batches():
    """D = 0.8 everywhere: -(ln 0.8 + ln 0.2) = 1.8326 (the 1e-7 guards change it by less than 1e-6)."""
    discriminator = constant_discriminator(0.8)
    states, actions = torch.zeros(4, 2), torch.zeros(4, 1)
    loss, _, accuracy = discriminator.losses(states, actions, states, actions, discriminator.loss_noise(4))
    assert loss.item() == pytest.approx(1.8325808, rel=1e-5)
    assert accuracy.item() == 0.5  # every expert sample right, every agent sample wrong


def known_curiosity() -> MlAgentsCuriosity:
    """1-d observations and features: phi(0) = swish(swish(0)) = 0, and a forward model predicting 2."""
    curiosity = MlAgentsCuriosity(1, 1, encoding_size=1)
    with torch.no_grad():
        curiosity.forward_model[-1].weight.zero_()
        curiosity.forward_model[-1].bias.fill_(2.0)
        for layer in (curiosity.encoder[0], curiosity.encoder[2]):
            layer.bias.zero_()
    curiosity.has_updated.fill_(True)
    return curiosity


@pytest.mark.parametrize(("strength", "reward"), [(0.02, 0.04), (0.1, 0.2), (1.0, 1.0)])
def test_curiosity_reward_is_the_strength_times_the_forward_error_clipped_to_one(strength, reward):
    """Surprise 1/2 (2 - phi(0))^2 = 2, times the strength, clipped to [0, 1]; no running-std rescale."""
    curiosity = known_curiosity()
    states, actions, next_states = torch.ones(2, 1), torch.zeros(2, 1), torch.zeros(2, 1)
    valid = torch.tensor([True, False])
    rewards = curiosity.reward(states, actions, next_states, valid, strength)
    assert rewards.tolist() == pytest.approx([reward, 0.0])
    # the same again: no running statistic moved it
    assert curiosity.reward(states, actions, next_states, valid, strength).tolist() == rewards.tolist()


def test_curiosity_pays_nothing_before_its_first_update():
    curiosity = known_curiosity()
    curiosity.has_updated.fill_(False)
    assert (
        curiosity.reward(torch.ones(1, 1), torch.zeros(1, 1), torch.zeros(1, 1), torch.ones(1) > 0, 1.0) == 0
    )
    forward_loss, _ = curiosity.losses(torch.ones(1, 1), torch.zeros(1, 1), torch.zeros(1, 1))
    assert forward_loss.item() == pytest.approx(2.0)  # the forward loss is the mean surprise
    assert curiosity.has_updated
