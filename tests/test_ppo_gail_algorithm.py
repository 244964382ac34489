"""Tests of the PPO + ICM + GAIL algorithm with rsl-rl's real ``OnPolicyRunner`` on a tiny real ``VecEnv``.

The environment is a batched 2-D point mass that must reach a goal; a scripted PD controller is the expert.
"""

from __future__ import annotations

import json
import os

os.environ.setdefault("GIT_PYTHON_REFRESH", "quiet")  # rsl-rl's logger imports GitPython

import numpy as np
import pytest
import torch
from cabinbench.baselines.ppo_gail import ABLATIONS, DemonstrationError, load_demonstrations, make_train_cfg
from rsl_rl.env import VecEnv
from rsl_rl.runners import OnPolicyRunner
from tensordict import TensorDict

OBSERVATION_CONFIG = {"policy": ["goal_relative_position_xy", "velocity_xy"]}
EXTRA_LOSSES = {
    "use_curiosity": ["curiosity_forward", "curiosity_inverse", "curiosity_reward"],
    "use_gail": ["gail_discriminator", "gail_gradient_penalty", "gail_accuracy", "gail_reward"],
}


# ----------------------------------------------------------------------------------------------------
# A tiny real environment and its expert
# ----------------------------------------------------------------------------------------------------


class PointMassEnv(VecEnv):
    """Batched 2-D point mass; the episode ends when it is within GOAL_RADIUS of the goal, or on the time
    limit.

    Observation: goal position relative to the mass, and velocity. Action: desired velocity in [-1, 1]^2,
    followed with a first-order lag. Reward: progress towards the goal plus 1 on success, or nothing
    (``extrinsic_reward`` False) when a test wants the agent to learn from the GAIL reward alone.
    """

    TIME_STEP = 0.1
    VELOCITY_LAG = 0.7
    GOAL_RADIUS = 0.1

    def __init__(
        self, num_envs: int = 32, max_episode_length: int = 50, seed: int = 0, extrinsic_reward=True
    ):
        self.num_envs = num_envs
        self.num_actions = 2
        self.max_episode_length = max_episode_length
        self.device = "cpu"
        self.cfg = {"task": "point_mass"}
        self.extrinsic_reward = extrinsic_reward
        self.generator = torch.Generator().manual_seed(seed)
        self.position = torch.zeros(num_envs, 2)
        self.velocity = torch.zeros(num_envs, 2)
        self.goal = torch.zeros(num_envs, 2)
        self.episode_length_buf = torch.zeros(num_envs, dtype=torch.long)
        self._reset(torch.ones(num_envs, dtype=torch.bool))

    def get_observations(self) -> TensorDict:
        observation = torch.cat([self.goal - self.position, self.velocity], dim=-1)
        return TensorDict({"policy": observation}, batch_size=[self.num_envs])

    def step(self, actions: torch.Tensor):
        distance_before = (self.goal - self.position).norm(dim=-1)
        self.velocity = self.VELOCITY_LAG * self.velocity + (1 - self.VELOCITY_LAG) * actions.clamp(-1, 1)
        self.position = (self.position + self.TIME_STEP * self.velocity).clamp(-1.5, 1.5)
        distance = (self.goal - self.position).norm(dim=-1)
        reached = distance < self.GOAL_RADIUS
        self.episode_length_buf += 1
        time_outs = (self.episode_length_buf >= self.max_episode_length) & ~reached
        rewards = (distance_before - distance) + reached.float()
        if not self.extrinsic_reward:
            rewards = torch.zeros_like(rewards)
        dones = reached | time_outs
        self._reset(dones)
        extras = {"time_outs": time_outs, "log": {"/success": reached.float()}}
        return self.get_observations(), rewards, dones.long(), extras

    def _reset(self, envs: torch.Tensor) -> None:
        count = int(envs.sum())
        self.position[envs] = torch.rand(count, 2, generator=self.generator) * 2 - 1
        self.goal[envs] = torch.rand(count, 2, generator=self.generator) * 2 - 1
        self.velocity[envs] = 0.0
        self.episode_length_buf[envs] = 0


def expert_actions(observations: torch.Tensor) -> torch.Tensor:
    """Scripted expert: a PD controller towards the goal (reaches it in every episode within ~30 steps)."""
    return (3.0 * observations[:, :2] - observations[:, 2:]).clamp(-1, 1)


def record_demonstrations(path, num_envs: int = 64, num_steps: int = 100, seed: int = 123) -> None:
    """Run the expert and write its (observation, action) pairs in the demonstration ``.npz`` schema."""
    env = PointMassEnv(num_envs, seed=seed)
    observations = env.get_observations()["policy"]
    episode = torch.arange(num_envs)
    next_episode = num_envs
    recorded = {"observations": [], "actions": [], "episode": []}
    for _ in range(num_steps):
        actions = expert_actions(observations)
        recorded["observations"].append(observations)
        recorded["actions"].append(actions)
        recorded["episode"].append(episode.clone())
        obs, _, dones, _ = env.step(actions)
        observations = obs["policy"]
        finished = dones.bool()
        episode[finished] = torch.arange(next_episode, next_episode + int(finished.sum()))
        next_episode += int(finished.sum())
    np.savez(
        path,
        observations=torch.cat(recorded["observations"]).numpy().astype(np.float32),
        actions=torch.cat(recorded["actions"]).numpy().astype(np.float32),
        episode=torch.cat(recorded["episode"]).numpy().astype(np.int32),
        observation_config=np.array(json.dumps(OBSERVATION_CONFIG)),
    )


def success_rate(policy, num_envs: int = 256, seed: int = 999) -> float:
    """Fraction of fresh episodes in which the deterministic policy reaches the goal before the time limit."""
    env = PointMassEnv(num_envs, seed=seed)
    obs = env.get_observations()
    succeeded = torch.zeros(num_envs, dtype=torch.bool)
    finished = torch.zeros(num_envs, dtype=torch.bool)
    with torch.inference_mode():
        for _ in range(env.max_episode_length):
            obs, _, dones, extras = env.step(policy(obs))
            first_end = dones.bool() & ~finished
            succeeded |= first_end & ~extras["time_outs"]
            finished |= first_end
    return succeeded.float().mean().item()


@pytest.fixture(scope="module")
def demonstrations(tmp_path_factory) -> str:
    path = tmp_path_factory.mktemp("demos") / "point_mass_expert.npz"
    record_demonstrations(path)
    return str(path)


def make_runner(variant, demonstrations, seed=0, env=None, log_dir=None, **cfg_kwargs) -> OnPolicyRunner:
    torch.manual_seed(seed)
    train_cfg = make_train_cfg(
        variant,
        expert_demonstrations=[demonstrations],
        expected_observation_config=OBSERVATION_CONFIG,
        **{"num_steps_per_env": 16, **cfg_kwargs},
    )
    return OnPolicyRunner(env or PointMassEnv(seed=seed), train_cfg, log_dir=log_dir, device="cpu")


def fixed_transitions(num_envs: int = 256, num_steps: int = 8, seed: int = 7):
    """(s, a, s') of random actions in the point mass, without transitions into a reset."""
    env = PointMassEnv(num_envs, seed=seed)
    generator = torch.Generator().manual_seed(seed)
    states, actions, next_states = [], [], []
    observations = env.get_observations()["policy"]
    for _ in range(num_steps):
        action = torch.rand(num_envs, 2, generator=generator) * 2 - 1
        obs, _, dones, _ = env.step(action)
        valid = dones == 0
        states.append(observations[valid])
        actions.append(action[valid])
        next_states.append(obs["policy"][valid])
        observations = obs["policy"]
    return torch.cat(states), torch.cat(actions), torch.cat(next_states)


def random_states(count: int, generator: torch.Generator) -> torch.Tensor:
    """Uniform point-mass observations: relative goal position in [-2, 2]^2, velocity in [-1, 1]^2."""
    goal = torch.rand(count, 2, generator=generator) * 4 - 2
    velocity = torch.rand(count, 2, generator=generator) * 2 - 1
    return torch.cat([goal, velocity], dim=-1)


# ----------------------------------------------------------------------------------------------------
# Tests
# ----------------------------------------------------------------------------------------------------


@pytest.mark.parametrize("variant", sorted(ABLATIONS))
def test_runner_trains_each_ablation_and_logs_extra_losses(variant, demonstrations, tmp_path, capsys):
    runner = make_runner(variant, demonstrations, log_dir=str(tmp_path))
    runner.learn(num_learning_iterations=2)

    printed = capsys.readouterr().out
    for flag, losses in EXTRA_LOSSES.items():
        for loss in losses:
            assert (f"Mean {loss} loss:" in printed) == ABLATIONS[variant][flag], (variant, loss)
    assert (tmp_path / "model_1.pt").is_file()


def test_curiosity_reward_is_zero_exactly_on_done_envs(demonstrations):
    # Rollouts longer than the time limit: every environment is done at least once.
    runner = make_runner("ppo_icm", demonstrations, num_steps_per_env=60)
    runner.learn(num_learning_iterations=1)

    alg = runner.alg
    done = alg.storage.dones.squeeze(-1).bool()
    assert done.any(dim=0).all()
    assert (alg.curiosity_rewards[done] == 0).all()
    assert (alg.curiosity_rewards[~done] > 0).all()


def test_curiosity_forward_loss_decreases_on_fixed_data(demonstrations):
    alg = make_runner("ppo_icm", demonstrations).alg
    states, actions, next_states = fixed_transitions()

    full_batches = [torch.arange(states.shape[0])] * 12  # an update's worth of optimiser steps
    losses = [alg.update_curiosity(states, actions, next_states, full_batches) for _ in range(10)]

    assert losses[-1]["curiosity_forward"] < 0.5 * losses[0]["curiosity_forward"]
    assert losses[-1]["curiosity_inverse"] < losses[0]["curiosity_inverse"]


def test_discriminator_separates_expert_from_random_pairs(demonstrations, tmp_path):
    alg = make_runner("ppo_gail_only", demonstrations).alg
    generator = torch.Generator().manual_seed(3)
    # Fixed agent data: random actions, half in random states and half in the expert's own states, so that D
    # has to judge the action as well as the state.
    num_expert = alg.expert_observations.shape[0]
    agent_states = torch.cat([alg.expert_observations, random_states(num_expert, generator)])
    agent_actions = torch.rand(2 * num_expert, 2, generator=generator) * 2 - 1
    batches = list(torch.arange(agent_states.shape[0]).chunk(4)) * 3
    for _ in range(20):
        expert = [torch.randint(num_expert, (batch.numel(),), generator=generator) for batch in batches]
        alg.update_discriminator(agent_states, agent_actions, batches, expert, [None] * len(batches))

    held_out = tmp_path / "held_out.npz"
    record_demonstrations(held_out, num_envs=32, num_steps=50, seed=456)
    states, actions = load_demonstrations(held_out, 4, 2)
    random_actions = torch.rand(actions.shape, generator=generator) * 2 - 1
    expert_reward = alg.discriminator.reward(states, actions)
    random_reward = alg.discriminator.reward(random_states(states.shape[0], generator), random_actions)
    random_action_reward = alg.discriminator.reward(states, random_actions)

    accuracy = 0.5 * ((expert_reward > 0).float().mean() + (random_reward < 0).float().mean())
    assert accuracy > 0.9
    # In the expert's states, the expert's action earns more than a random one.
    assert expert_reward.mean() > random_action_reward.mean()
    assert (expert_reward > random_action_reward).float().mean() > 0.9
    # The logit reward is a penalty where the agent does not look like the expert, not a bonus for being
    # alive.
    assert (random_reward < 0).float().mean() > 0.5


def test_gail_reward_is_centred_on_the_rollout_so_ending_early_pays_nothing(demonstrations):
    # No environment reward and no time-outs: what PPO's returns see is the GAIL reward alone.
    env = PointMassEnv(seed=0, max_episode_length=10_000, extrinsic_reward=False)
    runner = make_runner("ppo_gail_only", demonstrations, env=env)
    runner.learn(num_learning_iterations=2)

    alg = runner.alg
    assert alg.gail_rewards.abs().mean() > 1e-3  # the raw logit rewards are not zero...
    # ...but the rewards the returns were computed from are those minus their rollout mean.
    torch.testing.assert_close(alg.storage.rewards.squeeze(-1), alg.gail_rewards - alg.gail_rewards.mean())


def test_mlagents_gail_reward_is_paid_uncentred_once_the_discriminator_has_trained(demonstrations):
    # As in the test above, the returns see the GAIL reward alone.
    env = PointMassEnv(seed=0, max_episode_length=10_000, extrinsic_reward=False)
    runner = make_runner(
        "ppo_gail_only", demonstrations, env=env, gail_form="mlagents", gail_use_actions=False
    )
    runner.learn(num_learning_iterations=1)
    assert (runner.alg.gail_rewards == 0).all()  # ML-Agents pays nothing before the first update
    runner.learn(num_learning_iterations=1)

    alg = runner.alg
    assert (alg.gail_rewards > 0).all()  # -log(1 - D) is a bonus for every step
    torch.testing.assert_close(alg.storage.rewards.squeeze(-1), alg.gail_rewards)


def test_mlagents_curiosity_is_clipped_paid_after_its_first_update_and_trained_ten_times_harder(
    demonstrations,
):
    runner = make_runner("ppo_icm", demonstrations, curiosity_form="mlagents", num_steps_per_env=60)
    runner.learn(num_learning_iterations=1)
    assert (runner.alg.curiosity_rewards == 0).all()
    runner.learn(num_learning_iterations=1)
    alg = runner.alg
    done = alg.storage.dones.squeeze(-1).bool()
    assert (alg.curiosity_rewards[done] == 0).all()
    assert (alg.curiosity_rewards[~done] > 0).all() and (alg.curiosity_rewards <= 1).all()

    # One plain gradient step of the update is the gradient of 10 (0.2 L_F + 0.8 L_I).
    states, actions, next_states = fixed_transitions(num_envs=16, num_steps=2)
    parameters = list(alg.curiosity.parameters())
    forward_loss, inverse_loss = alg.curiosity.losses(states, actions, next_states)
    expected = torch.autograd.grad(10.0 * (0.2 * forward_loss + 0.8 * inverse_loss), parameters)
    before = [parameter.detach().clone() for parameter in parameters]
    alg.curiosity_optimizer = torch.optim.SGD(parameters, lr=1.0)
    alg.update_curiosity(states, actions, next_states, [torch.arange(states.shape[0])])
    for old, new, gradient in zip(before, parameters, expected, strict=True):
        torch.testing.assert_close(old - new.detach(), gradient)


def test_shaping_columns_are_all_that_the_icm_and_the_discriminator_see(demonstrations):
    # Only the relative goal position: the velocity stands in for a part of the observation, such as the
    # coverage patch, that the demonstrations show differently from the agent whatever the agent does.
    runner = make_runner("ppo_gail", demonstrations, shaping_columns=[0, 1])
    runner.learn(num_learning_iterations=2)

    alg = runner.alg
    assert alg.expert_observations.shape[1] == 2
    assert alg.curiosity.encoder(torch.zeros(1, 2)).shape == (1, 256)
    states = random_states(64, torch.Generator().manual_seed(0))
    actions = torch.zeros(64, 2)
    other_velocity = torch.cat([states[:, :2], -states[:, 2:]], dim=-1)
    rewards = [
        alg.discriminator.reward(
            alg._shaping_observation(TensorDict({"policy": s}, batch_size=[64])), actions
        )
        for s in (states, other_velocity)
    ]
    torch.testing.assert_close(rewards[0], rewards[1])
    with pytest.raises(RuntimeError):
        alg.discriminator.reward(states, actions)  # the whole observation does not fit D


def test_ppo_gail_learns_to_reach_the_goal_from_demonstrations_alone(demonstrations):
    # No environment reward: the only learning signal is the GAIL reward.
    env = PointMassEnv(seed=0, extrinsic_reward=False)
    runner = make_runner("ppo_gail_only", demonstrations, env=env, num_steps_per_env=24)
    initial = success_rate(runner.get_inference_policy())

    runner.learn(num_learning_iterations=25)

    final = success_rate(runner.get_inference_policy())
    assert initial < 0.2
    assert final > 0.5


def test_checkpoint_restores_icm_and_discriminator_with_weights_only_loading(demonstrations, tmp_path):
    trained = make_runner("ppo_gail", demonstrations, seed=0)
    trained.learn(num_learning_iterations=2)
    path = tmp_path / "checkpoint.pt"
    trained.save(str(path))

    restored = make_runner("ppo_gail", demonstrations, seed=1)
    assert not _state_equal(restored.alg.curiosity.state_dict(), trained.alg.curiosity.state_dict())
    checkpoint = torch.load(path, weights_only=True)
    restored.alg.load(checkpoint, load_cfg=None, strict=True)

    for module, optimizer in (
        ("curiosity", "curiosity_optimizer"),
        ("discriminator", "discriminator_optimizer"),
    ):
        assert _state_equal(
            getattr(restored.alg, module).state_dict(), getattr(trained.alg, module).state_dict()
        )
        assert _state_equal(
            getattr(restored.alg, optimizer).state_dict(), getattr(trained.alg, optimizer).state_dict()
        )
    assert _state_equal(restored.alg.actor.state_dict(), trained.alg.actor.state_dict())

    # Evaluating the policy needs neither the demonstrations nor the reward modules.
    policy_only = OnPolicyRunner(PointMassEnv(), make_train_cfg("ppo"), log_dir=None, device="cpu")
    policy_only.alg.load(checkpoint, load_cfg=None, strict=True)
    assert _state_equal(policy_only.alg.actor.state_dict(), trained.alg.actor.state_dict())


def _state_equal(a, b) -> bool:
    """Exact equality of nested state dicts (tensors, numbers, lists, dicts)."""
    if isinstance(a, torch.Tensor):
        return isinstance(b, torch.Tensor) and a.shape == b.shape and torch.equal(a, b)
    if isinstance(a, dict):
        return isinstance(b, dict) and a.keys() == b.keys() and all(_state_equal(a[k], b[k]) for k in a)
    if isinstance(a, (list, tuple)):
        return isinstance(b, (list, tuple)) and len(a) == len(b) and all(map(_state_equal, a, b))
    return a == b


def _write_demonstration(path, **overrides) -> str:
    """A valid 10-step demonstration file for the point mass, with keys replaced or (value None) removed."""
    arrays = {
        "observations": np.zeros((10, 4), np.float32),
        "actions": np.zeros((10, 2), np.float32),
        "episode": np.zeros(10, np.int32),
        "observation_config": np.array(json.dumps(OBSERVATION_CONFIG)),
    }
    arrays.update(overrides)
    np.savez(path, **{key: value for key, value in arrays.items() if value is not None})
    return str(path)


def test_demonstration_files_load_as_their_pairs_in_file_order(tmp_path):
    first_observations = np.arange(40, dtype=np.float32).reshape(10, 4)
    first = _write_demonstration(tmp_path / "first.npz", observations=first_observations)
    second = _write_demonstration(tmp_path / "second.npz", actions=np.full((10, 2), -0.5, np.float32))

    observations, actions = load_demonstrations(
        [first, second], 4, 2, expected_observation_config=OBSERVATION_CONFIG
    )

    assert observations.dtype == actions.dtype == torch.float32
    torch.testing.assert_close(observations[:10], torch.from_numpy(first_observations))
    torch.testing.assert_close(observations[10:], torch.zeros(10, 4))
    torch.testing.assert_close(actions, torch.cat([torch.zeros(10, 2), torch.full((10, 2), -0.5)]))


@pytest.mark.parametrize(
    ("overrides", "message"),
    [
        ({"actions": None}, r"missing key\(s\) \['actions'\]"),
        ({"observations": np.zeros((10, 5), np.float32)}, "observation size 5 does not match .* size 4"),
        ({"actions": np.zeros((10, 3), np.float32)}, "action size 3 does not match .* size 2"),
        ({"observations": np.zeros(10, np.float32)}, r"'observations' must have shape \[N, D\]"),
        ({"episode": np.zeros(9, np.int32)}, "inconsistent number of steps"),
        ({"observations": np.full((10, 4), np.nan, np.float32)}, "'observations' contains NaN"),
        ({"actions": np.full((10, 2), 2.0, np.float32)}, r"actions must lie in \[-1, 1\]"),
        ({"observation_config": np.array(json.dumps({"policy": ["lidar"]}))}, "does not match the expected"),
    ],
)
def test_demonstration_errors_name_the_file_and_the_problem(tmp_path, overrides, message):
    path = _write_demonstration(tmp_path / "bad.npz", **overrides)

    with pytest.raises(DemonstrationError, match=message) as error:
        load_demonstrations(path, 4, 2, expected_observation_config=OBSERVATION_CONFIG)
    assert "bad.npz" in str(error.value)


def test_gail_without_demonstrations_is_an_error():
    with pytest.raises(ValueError, match="expert_demonstrations"):
        OnPolicyRunner(PointMassEnv(), make_train_cfg("ppo_gail"), log_dir=None, device="cpu")
