"""What the clients users bring ask of the envs, on the real things: copies of an env in contacts,
actions of the wrong shape, team infos that TorchRL can convert, rsl-rl's runner (RND and random
episode lengths), a batched env whose worker dies, and ids that resolve without importing us."""

import copy
import os
import pickle
import signal
import subprocess
import sys
import textwrap
import time

import gymnasium as gym
import numpy as np
import pytest
import torch

import cabinbench
from cabinbench.envs.batch_engine import WorkerDied
from cabinbench.envs.batched import BatchedCoverageEnv, RslRlVecEnv
from cabinbench.envs.batched_team import BatchedTeamEnv, RslRlTeamVecEnv


def drive_into_contacts(step, action_of) -> None:
    """Full speed ahead, turning now and then, until the robots have touched walls a few times."""
    for t in range(120):
        step(action_of(np.array([1.0, 0.6 if t % 20 < 4 else 0.0])))


def test_a_copy_in_contacts_continues_exactly_like_the_original():
    env = gym.make("CabinBench/A320Cell-v0", lidar_noise=0.01).unwrapped
    env.reset(seed=0)
    drive_into_contacts(env.step, lambda action: action)
    assert env.tracker.collisions > 0
    actions = np.random.default_rng(0).uniform(-1, 1, (50, 2))
    copies = [copy.deepcopy(env), pickle.loads(pickle.dumps(env))]
    for envs in [env, *copies]:
        envs.trace = [np.append(envs.step(a)[0], envs.world.poses) for a in actions]
    for clone in copies:
        np.testing.assert_array_equal(np.array(clone.trace), np.array(env.trace))


def test_a_copy_of_the_team_env_continues_exactly_like_the_original():
    env = cabinbench.parallel_env(layout="a320_cell", n_agents=2)
    env.reset(seed=0)
    drive_into_contacts(env.step, lambda action: {agent: action for agent in env.agents})
    assert env.tracker.collisions + env.tracker.robot_collisions > 0
    clone = copy.deepcopy(env)
    rng = np.random.default_rng(1)
    for _ in range(50):
        actions = {agent: rng.uniform(-1, 1, 2) for agent in env.agents}
        original, copied = env.step(actions), clone.step(actions)
        for agent in env.possible_agents:
            np.testing.assert_array_equal(original[0][agent], copied[0][agent])
            assert original[1][agent] == copied[1][agent]
        np.testing.assert_array_equal(env.state(), clone.state())


def _steps_without_wall_time(env, actions) -> list:
    steps = []
    for action in actions:
        *tensors, finished = env.step(action)
        records = [
            (index, {k: v for k, v in record.items() if k != "wall_time"}) for index, record in finished
        ]
        steps.append((*tensors, records))
    return steps


@pytest.mark.parametrize(
    "make",
    [
        lambda workers: BatchedCoverageEnv(
            ["a320_cell", "a320_tracking_cell"],
            num_envs=5,
            seed=3,
            num_workers=workers,
            max_steps=23,
            random_start=True,
            lidar_noise=0.02,
            coverage_patch=8,
        ),
        lambda workers: BatchedTeamEnv(
            "a320_cell", num_envs=3, n_agents=2, seed=3, max_steps=23, random_start=True
        ),
    ],
    ids=["batched", "batched_team"],
)
def test_a_batch_restored_from_its_episodes_goes_on_exactly_as_the_original(make):
    """What a resumed training run relies on: a new batch (split over other workers) put back into the
    saved episodes, some in their second episode already, steps exactly as the original goes on."""
    original = make(2)
    actions = torch.rand((70, original.num_envs, 2), generator=torch.Generator().manual_seed(0)) * 2 - 1
    try:
        _steps_without_wall_time(original, actions[:30])
        saved = original.episodes()
        assert sorted({len(episode_actions) for _, episode_actions in saved}) == [7]  # 30 steps = 23 + 7
        restored = make(1)
        try:
            vec_env = (RslRlTeamVecEnv if isinstance(restored, BatchedTeamEnv) else RslRlVecEnv)(restored)
            vec_env.restore(saved)
            np.testing.assert_array_equal(vec_env.get_observations()["policy"].numpy(), original.observations)
            assert vec_env.episode_length_buf.tolist() == [7] * restored.num_envs
            after_original = _steps_without_wall_time(original, actions[30:])
            after_restored = _steps_without_wall_time(restored, actions[30:])
        finally:
            restored.close()
    finally:
        original.close()
    assert any(records for *_, records in after_original)  # episodes ended after the restore too
    for (*tensors, records), (*tensors_restored, records_restored) in zip(after_original, after_restored):
        for tensor, tensor_restored in zip(tensors, tensors_restored):
            assert torch.equal(tensor, tensor_restored)
        assert records == records_restored


@pytest.mark.parametrize("shape", [(4,), (2, 1), (), (1, 2)])
def test_actions_of_another_shape_are_refused_with_the_expected_shape(shape):
    env = gym.make("CabinBench/A320Cell-v0").unwrapped
    env.reset(seed=0)
    with pytest.raises(ValueError, match=r"action must have shape \(2,\)"):
        env.step(np.zeros(shape))
    team = cabinbench.parallel_env(layout="a320_cell", n_agents=2)
    team.reset(seed=0)
    with pytest.raises(ValueError, match=r"the action of robot_1 must have shape \(2,\)"):
        team.step({"robot_0": np.zeros(2), "robot_1": np.zeros(shape)})
    with pytest.raises(ValueError, match="actions must be a dict of agent name to action"):
        team.step([np.zeros(2), np.zeros(shape)])


@pytest.mark.parametrize(
    "make, name, value",
    [
        (BatchedCoverageEnv, "num_envs", 0),
        (BatchedCoverageEnv, "num_envs", 2.5),
        (BatchedCoverageEnv, "num_workers", 0),
        (BatchedTeamEnv, "num_envs", 0),
    ],
)
def test_a_batch_of_no_envs_or_workers_is_refused_naming_the_argument(make, name, value):
    with pytest.raises(ValueError, match=f"^{name} must be a whole number >= 1"):
        make("a320_cell", **{name: value})


def test_team_infos_without_the_record_keep_the_reset_keys_and_convert_to_tensors():
    """TorchRL's PettingZooWrapper builds its info spec from the reset's infos, then writes every
    step's info values into it with ``torch.tensor``."""
    env = cabinbench.parallel_env(layout="a320_cell", n_agents=2, max_steps=15)
    _, infos = env.reset(seed=0)
    spec = {
        agent: {key: torch.as_tensor(value).shape for key, value in info.items()}
        for agent, info in infos.items()
    }
    for _ in range(15):
        _, _, _, truncations, infos = env.step({agent: np.array([0.5, 0.1]) for agent in env.agents})
        for agent, info in infos.items():
            assert {key: torch.tensor(value).shape for key, value in info.items()} == spec[agent]
    assert all(truncations.values()) and env.episode_record["steps"] == 15
    assert env.episode_record["t90"] is None  # the record itself is unchanged


def test_torchrl_pettingzoo_wrapper_rolls_over_episode_ends():
    pytest.importorskip("torchrl")
    from torchrl.envs.libs.pettingzoo import PettingZooWrapper

    env = PettingZooWrapper(
        cabinbench.parallel_env(layout="a320_cell", n_agents=2, max_steps=10),
        use_mask=True,
    )
    rollout = env.rollout(25, break_when_any_done=False)
    assert rollout["next", "done"].sum() >= 2


def test_rsl_rl_runner_learns_with_random_episode_lengths_and_rnd():
    from rsl_rl.runners import OnPolicyRunner

    env = RslRlVecEnv(BatchedCoverageEnv("a320_cell", num_envs=4, seed=0, max_steps=30))
    assert env.unwrapped is env and env.step_dt == pytest.approx(0.1) and env.max_episode_length == 30
    train_cfg = {
        "num_steps_per_env": 8,
        "save_interval": 100,
        "obs_groups": {"actor": ["policy"], "critic": ["policy"], "rnd_state": ["policy"]},
        "algorithm": {
            "class_name": "PPO",
            "num_learning_epochs": 1,
            "num_mini_batches": 1,
            "rnd_cfg": {
                "num_outputs": 4,
                "predictor_hidden_dims": [8],
                "target_hidden_dims": [8],
                "weight": 1.0,
            },
        },
        "actor": {
            "class_name": "MLPModel",
            "hidden_dims": [16],
            "activation": "elu",
            "distribution_cfg": {"class_name": "GaussianDistribution", "init_std": 1.0},
        },
        "critic": {"class_name": "MLPModel", "hidden_dims": [16], "activation": "elu"},
    }
    runner = OnPolicyRunner(env, train_cfg, log_dir=None, device="cpu")
    before = [parameter.detach().clone() for parameter in runner.alg.rnd.predictor.parameters()]
    runner.learn(1, init_at_random_ep_len=True)
    after = list(runner.alg.rnd.predictor.parameters())
    assert any(not torch.equal(a, b) for a, b in zip(before, after))  # one update, curiosity included
    env.env.close()


def test_a_worker_killed_between_steps_raises_instead_of_hanging():
    env = BatchedCoverageEnv("a320_cell", num_envs=4, seed=0, num_workers=2)
    env.step(torch.zeros(4, 2))
    os.kill(env.workers[0][1].pid, signal.SIGKILL)
    with pytest.raises(WorkerDied, match="worker 1 of the batched env died while stepping"):
        env.step(torch.zeros(4, 2))
    assert env.workers == []


def test_a_script_without_a_main_guard_fails_with_a_clear_error(tmp_path):
    """Spawned workers re-import the script; the worker's copy then fails to start its own workers."""
    script = tmp_path / "train.py"
    script.write_text(
        textwrap.dedent(
            """
            from cabinbench.envs.batched import BatchedCoverageEnv

            env = BatchedCoverageEnv("a320_cell", num_envs=2, num_workers=2)
            """
        )
    )
    result = subprocess.run(
        [sys.executable, str(script)], capture_output=True, text=True, timeout=120, cwd=tmp_path
    )
    assert result.returncode != 0
    assert "WorkerDied" in result.stderr and "if __name__ == '__main__':" in result.stderr


CTRL_C_SCRIPT = """
import os, sys, torch
from cabinbench.envs.batched import BatchedCoverageEnv

if __name__ == "__main__":
    env = BatchedCoverageEnv("a320_cell", num_envs=4, num_workers=3, max_steps=20)  # 2 worker processes
    workers = [process.pid for _, process in env.workers]
    print(*workers, flush=True)
    try:
        while True:
            env.step(torch.zeros(4, 2))
    except KeyboardInterrupt:  # in a step (the env stopped its workers) or between two
        env.close()
        print("interrupted", file=sys.stderr)
        sys.exit(130)
"""


def as_a_terminal_starts_it() -> None:
    """A terminal's job starts with Ctrl-C at its default and unblocked, whatever the test process's own
    signal state (a child inherits a blocked or ignored SIGINT through exec)."""
    signal.pthread_sigmask(signal.SIG_SETMASK, [])
    signal.signal(signal.SIGINT, signal.SIG_DFL)


def test_ctrl_c_while_stepping_stops_the_workers_without_their_tracebacks(tmp_path):
    """A terminal sends Ctrl-C (SIGINT) to the whole process group: the workers must leave the
    decision to the main process, which stops them and raises KeyboardInterrupt."""
    script = tmp_path / "train.py"
    script.write_text(CTRL_C_SCRIPT)
    process = subprocess.Popen(
        [sys.executable, str(script)],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        cwd=tmp_path,
        start_new_session=True,  # its own process group, as a terminal's foreground job
        preexec_fn=as_a_terminal_starts_it,
    )
    try:
        workers = [int(pid) for pid in process.stdout.readline().split()]  # the workers are up
        time.sleep(1.0)  # the batch steps
        os.killpg(process.pid, signal.SIGINT)
        _, stderr = process.communicate(timeout=60)
    finally:
        process.kill()
    assert len(workers) == 2 and process.returncode == 130, stderr
    assert "Traceback" not in stderr and "WorkerDied" not in stderr and "interrupted" in stderr, stderr
    deadline = time.monotonic() + 10
    while any(os.path.exists(f"/proc/{pid}") for pid in workers) and time.monotonic() < deadline:
        time.sleep(0.1)
    assert not any(os.path.exists(f"/proc/{pid}") for pid in workers)  # no worker outlives the run


def test_an_id_resolves_in_a_process_that_never_imports_cabinbench():
    code = (
        "import gymnasium; print(gymnasium.make('cabinbench:CabinBench/A320Cell-v0').unwrapped.layout.name)"
    )
    result = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120)
    assert result.returncode == 0, result.stderr
    assert result.stdout.strip() == "a320_cell"
