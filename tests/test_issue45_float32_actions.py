"""Baselines return float32 actions, as the action space holds them (issue 45, item 8: a Minari dataset
recorded from ``act`` failed ``action_space.contains``), while ``run`` keeps stepping the env with the
exact actions every committed record was played with (``agents.Baseline``)."""

from __future__ import annotations

import json
from pathlib import Path

import gymnasium as gym
import numpy as np
import pytest
import torch
import torch.nn as nn
from cabinbench.baselines.ppo_gail.policy import CHECKPOINT_DIR, write_policy_file

import cabinbench
from cabinbench.agents import EpisodeContext, load_baseline, registered_baselines
from cabinbench.envs.settings import observation_config
from cabinbench.episodes import make_env, run_episode
from cabinbench.layouts.resolve import load_layout

STEPS = 40
RUNS = Path(__file__).resolve().parents[1] / "results" / "runs"
# what load_baseline needs beyond its defaults; a policy file the repository does not ship is written here
PLAN = "x,y\n0.25,1.85\n0.6,1.85\n0.6,2.05\n"
TEAM = {"ppo_gail_team": 2}


def lidar_and_velocity_policy(path: Path) -> Path:
    """An untrained ``ppo_lstm`` policy file (the format's ``memory``): its actions are as good as any."""
    size = make_env(load_layout("a320_cell"), "sequential", 1, {}).observation_layout["velocity"].stop
    lstm = nn.LSTM(size, 8)
    memory = {
        "rnn_type": "lstm",
        "input_size": size,
        "hidden_size": 8,
        "num_layers": 1,
        "obs_normalizer": None,
    }
    memory["state_dict"] = {key: value.detach().clone() for key, value in lstm.state_dict().items()}
    return write_policy_file(
        path,
        nn.Sequential(nn.Linear(8, 2)),
        "elu",
        ablation="ppo_lstm",
        obs_normalizer=None,
        action_std=torch.full((2,), 0.5),
        observation_config=observation_config({}, size),
        memory=memory,
    )


def baseline_config(name: str, folder: Path) -> dict:
    if name == "path":
        (folder / "plan.csv").write_text(PLAN)
        return {"file": str(folder / "plan.csv")}
    if name == "onnx":
        return {"file": str(CHECKPOINT_DIR / "ppo_gail.onnx")}  # stochastic: float64 noise on float32 means
    if name == "ppo_lstm":
        return {"checkpoint": str(lidar_and_velocity_policy(folder / "ppo_lstm.pt"))}
    if name in ("bc", "dagger") and not (CHECKPOINT_DIR / f"{name}.pt").exists():
        policy = torch.load(CHECKPOINT_DIR / "ppo.pt", weights_only=True)  # the same format, another name
        torch.save({**policy, "ablation": name}, folder / f"{name}.pt")
        return {"checkpoint": str(folder / f"{name}.pt")}
    return {}


@pytest.mark.parametrize("name", list(registered_baselines()))
def test_every_baselines_actions_lie_in_the_action_space_as_float32(name, tmp_path):
    n_agents = TEAM.get(name, 1)
    baselines = [load_baseline(name, **baseline_config(name, tmp_path)) for _ in range(n_agents)]
    env_kwargs = {**baselines[0].env_options, "max_steps": STEPS}
    env = make_env(load_layout("a320_cell"), "sequential", n_agents, env_kwargs)
    observations, infos = env.reset(seed=0)
    team_start = np.array([infos[agent]["pose"] for agent in env.agents])
    for seat, (agent, baseline) in enumerate(zip(env.agents, baselines)):
        context = EpisodeContext(
            env.layout, "sequential", 0, seat, n_agents, env_kwargs, env.observation_layout, team_start
        )
        baseline.reset(context, observations[agent], infos[agent])
    steps = 0
    while env.agents:
        actions = {
            agent: baseline.act(observations[agent], infos[agent])
            for agent, baseline in zip(env.agents, baselines)
        }
        for agent, action in actions.items():
            assert action.dtype == np.float32 and env.action_space(agent).contains(action), (steps, action)
        observations, _, _, _, infos = env.step(actions)
        steps += 1
    assert steps == STEPS


def shortest_committed_record(baseline: str) -> dict:
    records = [
        json.loads(line)
        for path in RUNS.glob(f"*__{baseline}__*.jsonl")
        for line in path.read_text().splitlines()
        if line.strip()
    ]
    return min(records, key=lambda record: (record["steps"], record["layout"], record["seed"]))


@pytest.mark.parametrize("baseline", ["boustrophedon", "ppo", "ppo_lstm"])
def test_run_plays_the_exact_actions_its_committed_records_were_played_with(baseline):
    """float32 actions would move these records: the planner's path length in the 9th digit, the
    stochastic policy's (float32 means plus float64 noise) coverage in the 3rd. The policy files, written
    before their ``inference`` entry, act in float32 as they did, a recurrent one's memory too (issue 44)."""
    record = shortest_committed_record(baseline)
    replayed, _ = run_episode(
        baseline,
        record["layout"],
        record["seed"] + record["episode"],
        record["protocol"],
        record["n_agents"],
        record["env_config"],
        record["baseline_config"],
    )
    for name in ("coverage", "path_length", "rotation", "steps", "collisions"):
        assert replayed[name] == record[name], name


def context_of(env, seed: int, agent: int = 0, n_agents: int = 1, team_start=None) -> EpisodeContext:
    core = env.unwrapped  # every env here plays the default protocol
    return EpisodeContext(
        core.layout, "sequential", seed, agent, n_agents, {}, core.observation_layout, team_start
    )


@pytest.mark.parametrize(
    ("env_id", "baseline", "settings"),
    [
        ("CabinBench/ShapeChanged-v0", "boustrophedon", {}),  # clears both cells, then succeeds
        ("CabinBench/A320Cell-v0", "random_bounce", {"max_steps": 300}),  # bumps into seats
        ("CabinBench/Suite-v0", "boustrophedon", {"suite": "cabin-v1-test"}),
    ],
)
def test_a_whole_episode_keeps_the_reset_info_keys_and_float32_actions_in_the_space(
    env_id, baseline, settings
):
    """What Minari's record_infos and ``action_space.contains`` check at every step of a dataset, through
    the events of an episode (contacts, cells cleared, success) to its last step."""
    env = gym.make(env_id, **settings)
    observation, info = env.reset(seed=1)
    keys, player = set(info), load_baseline(baseline)
    player.reset(context_of(env, 1), observation, info)
    over, steps = False, 0
    while not over:
        action = player.act(observation, info)
        assert action.dtype == np.float32 and env.action_space.contains(action)
        observation, _, terminated, truncated, info = env.step(action)
        over, steps = terminated or truncated, steps + 1
        assert set(info) == keys and all(
            isinstance(value, (np.generic, np.ndarray)) for value in info.values()
        )
    record = env.unwrapped.episode_record
    assert record["steps"] == steps and (record["success"] or record["collisions"] > 0)


def test_a_whole_team_episode_keeps_the_reset_info_keys_and_float32_actions_in_the_space():
    env = cabinbench.parallel_env(layout="a320_cell", n_agents=2)
    observations, infos = env.reset(seed=0)
    keys = {agent: set(info) for agent, info in infos.items()}
    start = np.array([infos[agent]["pose"] for agent in env.agents])
    players = {agent: load_baseline("boustrophedon") for agent in env.agents}
    for seat, (agent, player) in enumerate(players.items()):
        player.reset(context_of(env, 0, seat, 2, start), observations[agent], infos[agent])
    while env.agents:
        actions = {agent: player.act(observations[agent], infos[agent]) for agent, player in players.items()}
        assert all(env.action_space(agent).contains(action) for agent, action in actions.items())
        observations, _, _, _, infos = env.step(actions)
        assert {agent: set(info) for agent, info in infos.items()} == keys
    assert env.unwrapped.episode_record["success"]
