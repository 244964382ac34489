"""The published demonstrations (``baselines/ppo_gail/datasets.py``): varied episodes over several cells,
loaded back as a Minari dataset (one robot) and as the team ``.npz`` that GAIL reads."""

from __future__ import annotations

import json

import minari
import numpy as np
from cabinbench.baselines.ppo_gail.datasets import record_team_npz, write_minari_dataset
from cabinbench.baselines.ppo_gail.demonstrations import load_demonstrations

LAYOUTS = ["a320_cell", "a320_tracking_cell"]


def test_the_minari_dataset_loads_back_as_varied_episodes_of_each_cell(tmp_path, monkeypatch):
    monkeypatch.setenv("MINARI_DATASETS_PATH", str(tmp_path))
    write_minari_dataset("cabinbench/test-v0", LAYOUTS, 2, seed=0, max_steps=40)

    dataset = minari.load_dataset("cabinbench/test-v0")
    episodes = list(dataset.iterate_episodes())
    assert dataset.total_episodes == 4 and dataset.total_steps == 4 * 40
    for episode in episodes:
        assert episode.observations.shape == (41, dataset.observation_space.shape[0])
        assert episode.actions.shape == (40, 2) and np.abs(episode.actions).max() <= 1
        assert episode.truncations[-1] and not episode.terminations.any()  # the step limit ended it
    assert [episode.id for episode in episodes] == [0, 1, 2, 3]
    # another start pose in every episode of a cell, and the two cells' observations differ
    assert not np.array_equal(episodes[0].observations[0], episodes[1].observations[0])
    assert not np.array_equal(episodes[0].observations, episodes[2].observations)
    assert "episodes 2-3: a320_tracking_cell" in dataset.storage.metadata["description"]


def test_the_team_npz_is_gail_demonstrations_with_each_rows_robot_and_episode_layout(tmp_path):
    path = tmp_path / "team.npz"
    summary = record_team_npz(path, LAYOUTS, 2, n_agents=2, max_steps=20)

    with np.load(path) as data:
        arrays = {key: data[key] for key in data.files}
    size = arrays["observations"].shape[1]
    observations, actions = load_demonstrations(path, size, 2)
    assert observations.shape[0] == actions.shape[0] == summary["steps"] == 2 * 2 * 2 * 20
    assert arrays["agent"].tolist() == [0, 1] * (summary["steps"] // 2)
    assert arrays["episode"].tolist() == [episode for episode in range(4) for _ in range(40)]
    assert arrays["episode_layout"].tolist() == ["a320_cell"] * 2 + ["a320_tracking_cell"] * 2
    assert int(arrays["n_agents"]) == 2 and json.loads(str(arrays["observation_config"]))
    # the two episodes of a cell start from different poses
    first = [arrays["observations"][arrays["episode"] == episode][0] for episode in (0, 1)]
    assert not np.array_equal(first[0], first[1])
