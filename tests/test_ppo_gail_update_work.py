"""The work ``PPOCuriosityGail`` saves gives the numbers of the work it saves: the ICM encoding of s_t reused
from the step before, the critic's observation statistics taken from the actor's, and the ICM and the
discriminator trained in threads beside PPO. On the point mass of ``test_ppo_gail_algorithm``."""

from __future__ import annotations

import copy

import pytest
import torch

from tests.test_ppo_gail_algorithm import make_runner, record_demonstrations


@pytest.fixture(scope="module")
def demonstrations(tmp_path_factory) -> str:
    path = tmp_path_factory.mktemp("demos") / "point_mass_expert.npz"
    record_demonstrations(path)
    return str(path)


def test_each_curiosity_reward_is_that_of_its_transition_encoded_afresh(demonstrations):
    # rollouts past the time limit: the reused encodings of envs that were reset are among them
    runner = make_runner("ppo_icm", demonstrations, num_steps_per_env=60)
    runner.learn(num_learning_iterations=1)  # trained: its running std is no longer the initial one
    alg = runner.alg
    fresh = copy.deepcopy(alg.curiosity)
    runner.learn(num_learning_iterations=1)

    storage = alg.storage
    for step in range(storage.num_transitions_per_env):
        expected = fresh.reward(
            storage.observations[step]["policy"],
            storage.actions[step].clamp(-1.0, 1.0),
            alg.next_states[step],
            storage.dones[step].squeeze(-1) == 0,
            alg.curiosity_strength,
        )
        assert torch.equal(alg.curiosity_rewards[step], expected), step
    assert storage.dones.any()


def test_the_critic_takes_the_actors_statistics_only_where_they_were_its_own(demonstrations):
    runner = make_runner("ppo", demonstrations)
    runner.learn(num_learning_iterations=2)
    actor, critic = runner.alg.actor.obs_normalizer, runner.alg.critic.obs_normalizer
    for name, buffer in actor.named_buffers():
        assert torch.equal(buffer, critic.get_buffer(name)), name
        assert buffer is not critic.get_buffer(name)
    assert int(critic.count) == 2 * 16 * 32

    critic._mean.add_(1.0)  # statistics of its own from here on
    own = copy.deepcopy(critic)
    runner.learn(num_learning_iterations=1)
    own.update(runner.alg.storage.observations.flatten(0, 1)["policy"])
    for name, buffer in own.named_buffers():
        assert torch.equal(buffer, critic.get_buffer(name)), name
    assert not torch.equal(actor._mean, critic._mean)


def test_the_updates_do_not_depend_on_the_threads_beside_ppo(demonstrations):
    trained = []
    for threads in (0, 1, 2):
        runner = make_runner("ppo_gail", demonstrations, shaping_update_threads=threads)
        runner.learn(num_learning_iterations=2)
        trained.append(runner.alg.save())
    for other in trained[1:]:
        for key in (
            "actor_state_dict",
            "critic_state_dict",
            "curiosity_state_dict",
            "discriminator_state_dict",
        ):
            for name, tensor in trained[0][key].items():
                assert torch.equal(tensor, other[key][name]), (key, name)
