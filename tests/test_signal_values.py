"""A value head per reward signal (``value_per_signal``), as ML-Agents' PPO trains the study's critic: returns
checked by hand on a rollout with an episode that ends and one that times out, and training with rsl-rl's
real runner."""

from __future__ import annotations

import pytest
import torch
from cabinbench.baselines.ppo_gail import make_train_cfg
from cabinbench.baselines.ppo_gail.signal_values import SignalValues
from rsl_rl.runners import OnPolicyRunner
from rsl_rl.storage import RolloutStorage
from tensordict import TensorDict

from tests.test_ppo_gail_algorithm import (
    OBSERVATION_CONFIG,
    PointMassEnv,
    make_runner,
    record_demonstrations,
)

GAMMA = 0.5
MLAGENTS_FORMS = {"curiosity_form": "mlagents", "gail_form": "mlagents", "gail_use_actions": False}


@pytest.fixture(scope="module")
def demonstrations(tmp_path_factory) -> str:
    """The point mass's expert, as ``test_ppo_gail_algorithm`` records it."""
    path = tmp_path_factory.mktemp("demos") / "point_mass_expert.npz"
    record_demonstrations(path)
    return str(path)


def hand_made_rollout(lam: float, normalise: bool = False) -> SignalValues:
    """Two envs, three steps, signals (extrinsic, gail). At step 1 env 0's episode ends at the exit and
    env 1's times out. The environment pays 1, 2, 0 and GAIL 0.25 at every step."""
    storage = RolloutStorage(
        "rl", 2, 3, TensorDict({"policy": torch.zeros(2, 1)}, batch_size=[2]), [1], "cpu"
    )
    signal_values = SignalValues(storage, ("extrinsic", "gail"), GAMMA, lam, normalise)
    values = torch.tensor(
        [
            [[1.0, 4.0], [1.5, 4.5]],  # step 0: env 0's (extrinsic, gail) values, env 1's
            [[2.0, 6.0], [2.5, 6.5]],
            [[3.0, 8.0], [3.5, 8.5]],
        ]
    )
    storage.values.copy_(values)
    for step, (reward, done, time_out) in enumerate(
        [((1.0, 1.0), (0, 0), (0, 0)), ((2.0, 2.0), (1, 1), (0, 1)), ((0.0, 0.0), (0, 0), (0, 0))]
    ):
        storage.dones[step, :, 0] = torch.tensor(done)
        signal_values.record(
            step,
            {"extrinsic": torch.tensor(reward), "gail": torch.full((2,), 0.25)},
            values[step],
            torch.tensor(done),
            {"time_outs": torch.tensor(time_out)},
        )
    signal_values.compute_returns(last_values=torch.tensor([[10.0, 20.0], [10.0, 20.0]]))
    return signal_values


def test_only_the_extrinsic_return_ends_with_an_episode_and_a_time_out_bootstraps_every_signal():
    storage = hand_made_rollout(lam=1.0).storage  # lam 1: discounted rewards to the bootstrap
    last = 0.0 + GAMMA * 10.0, 0.25 + GAMMA * 20.0  # step 2, from the values after the rollout
    expected_step_1 = [
        [2.0, 0.25 + GAMMA * 6.0],  # env 0 reached the exit: the extrinsic return stops; GAIL's goes on
        [2.0 + GAMMA * 2.5, 0.25 + GAMMA * 6.5],  # env 1 timed out: both go on
    ]
    expected = torch.tensor(
        [
            [
                [reward + GAMMA * r for reward, r in zip((1.0, 0.25), expected_step_1[env])]
                for env in range(2)
            ],
            expected_step_1,
            [last, last],
        ]
    )
    torch.testing.assert_close(storage.returns, expected)
    # the advantage PPO optimises: the mean of the signals', here not normalised
    torch.testing.assert_close(storage.advantages, (expected - storage.values).mean(-1, keepdim=True))


def test_gae_lambda_zero_is_the_one_step_td_target_of_each_signal():
    storage = hand_made_rollout(lam=0.0).storage
    expected = torch.tensor(
        [
            [[1.0 + GAMMA * 2.0, 0.25 + GAMMA * 6.0], [1.0 + GAMMA * 2.5, 0.25 + GAMMA * 6.5]],
            [[2.0, 0.25 + GAMMA * 6.0], [2.0 + GAMMA * 2.5, 0.25 + GAMMA * 6.5]],
            [[GAMMA * 10.0, 0.25 + GAMMA * 20.0]] * 2,
        ]
    )
    torch.testing.assert_close(storage.returns, expected)


def test_the_mean_advantage_is_normalised_over_the_rollout():
    advantages = hand_made_rollout(lam=0.95, normalise=True).storage.advantages
    assert advantages.shape == (3, 2, 1)
    torch.testing.assert_close(advantages.mean(), torch.tensor(0.0))
    torch.testing.assert_close(advantages.std(), torch.tensor(1.0), atol=1e-6, rtol=0)


def test_training_keeps_a_value_per_signal_and_bootstraps_gail_where_an_episode_ends(
    demonstrations, tmp_path
):
    # Episodes of at most 30 steps, rollouts of 60: every env ends one at least once in a rollout.
    env = PointMassEnv(seed=0, max_episode_length=30)
    runner = make_runner(
        "ppo_gail",
        demonstrations,
        env=env,
        log_dir=str(tmp_path),
        num_steps_per_env=60,
        value_per_signal=True,
        **MLAGENTS_FORMS,
    )
    runner.learn(num_learning_iterations=3)
    alg = runner.alg
    assert alg.critic(env.get_observations()).shape == (env.num_envs, 3)
    assert alg.storage.returns.shape == (60, env.num_envs, 3) and alg.storage.advantages.shape[-1] == 1

    done = alg.storage.dones.squeeze(-1).bool()
    values = alg.storage.values
    assert done.any()
    extrinsic, gail = alg.signal_values.of("extrinsic")[..., 0], alg.signal_values.of("gail")[..., 0]
    rewards = alg.storage.rewards[..., 0]  # the environment's
    reached = done & (rewards > 0.5)  # the point mass pays 1 at the goal
    assert reached.any() and (done & ~reached).any()
    # GAIL's reward, plus the value of s_t wherever its episode ended (at the goal, or the time limit) ...
    torch.testing.assert_close(gail, alg.gail_rewards + alg.gamma * values[..., 2] * done)
    # ... the environment's, plus it at time-outs only
    torch.testing.assert_close(extrinsic, rewards + alg.gamma * values[..., 0] * (done & ~reached))

    # the checkpoint restores the three-valued critic
    again = make_runner(
        "ppo_gail", demonstrations, seed=1, num_steps_per_env=60, value_per_signal=True, **MLAGENTS_FORMS
    )
    again.load(str(tmp_path / "model_2.pt"))
    observations = env.get_observations()
    torch.testing.assert_close(again.alg.critic(observations), alg.critic(observations))


def test_a_value_per_signal_needs_a_critic_of_as_many_values(demonstrations):
    train_cfg = make_train_cfg(
        "ppo_icm",
        expert_demonstrations=[demonstrations],
        expected_observation_config=OBSERVATION_CONFIG,
        value_per_signal=True,
    )
    assert train_cfg["critic"]["num_values"] == 2  # extrinsic and curiosity
    train_cfg["critic"] = train_cfg["actor"] | {"class_name": "MLPModel", "distribution_cfg": None}
    with pytest.raises(ValueError, match="SignalValueCritic of 2 values"):
        OnPolicyRunner(PointMassEnv(), train_cfg, log_dir=None, device="cpu")
