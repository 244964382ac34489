"""Cabin families, suites and the suite protocol: the generator is pure and its layouts pass the
loader's validation; the suites are what their manifests say, split without leaks; suite layout
names load everywhere a layout name does; ``run --suite`` and ``CabinBench/Suite-v0`` play them."""

import json
import math
import subprocess
import sys

import gymnasium as gym
import numpy as np
import pytest

import cabinbench
from cabinbench import load_layout
from cabinbench.commands import complexity, suites
from cabinbench.commands.run import main as run_main
from cabinbench.errors import LayoutError
from cabinbench.layouts.family import families_dir, generate, load_family
from cabinbench.layouts.load import parse_layout
from cabinbench.layouts.model import geometry_hash
from cabinbench.layouts.suites import available_suites, get_suite, shared_layouts, verify
from cabinbench.records import read_records
from cabinbench.sim.world import random_start_poses, start_cell_spots
from cabinbench.stats import stratified_bootstrap

GENERATED = [name for name, suite in available_suites().items() if suite.family]
# a spread sample of every generated suite, as the env tests loop over registered ids
SAMPLE = [
    name
    for suite in GENERATED
    for name in get_suite(suite).layout_names[:: max(1, len(get_suite(suite)) // 4)][:4]
]


def test_the_shipped_suites_have_their_sizes_and_families():
    sizes = {name: len(suite) for name, suite in available_suites().items()}
    assert sizes["cabin-v1-train"] >= 500 and sizes["cabin-v1-test"] >= 100 and sizes["cabin-v1-ood"] >= 50
    classic = get_suite("classic")
    assert set(classic.layout_names) <= set(cabinbench.available_layouts())
    assert get_suite("cabin-v1-test").layout_names[7] == "cabin-v1-test/0007"
    for suite in available_suites().values():
        assert suite.version >= 1 and set(suite.content_hashes()) == set(suite.layout_names)


def test_test_and_ood_share_no_layout_with_train():
    train = set(get_suite("cabin-v1-train").content_hashes().values())
    for held_out in ("cabin-v1-test", "cabin-v1-ood"):
        assert not train & set(get_suite(held_out).content_hashes().values())
    assert shared_layouts() == []


def test_ood_is_outside_the_training_distribution():
    train, ood = get_suite("cabin-v1-train").manifest(), get_suite("cabin-v1-ood").manifest()
    assert not {e["seats"] for e in train.values()} & {e["seats"] for e in ood.values()}
    assert max(e["cells"] for e in train.values()) < max(e["cells"] for e in ood.values())
    assert np.median([e["size_m"][0] for e in ood.values()]) > np.median(
        [e["size_m"][0] for e in train.values()]
    )
    configurations = {
        tuple(c["seats"]) for f in ("cabin_v1", "cabin_v1_ood") for c in load_family(f).spec["configurations"]
    }
    assert {(2, 2), (3, 3), (2, 3), (2, 3, 2), (3, 3, 3), (3, 4, 3)} <= configurations


@pytest.mark.parametrize("name", SAMPLE)
def test_every_sampled_suite_layout_is_what_the_manifest_says(name):
    suite = get_suite(name.split("/")[0])
    assert verify(suite, [name]) == []
    layout = load_layout(name)
    assert layout.name == name and layout.content_hash == suite.content_hashes()[name]
    # clutter cut nothing off: every pose the robot fits in is reachable from the start
    assert int((layout.clearance >= layout.robot.radius + 0.01).sum()) == int(layout.centre_free.sum())
    assert layout.max_steps >= 300 * layout.coverable_area  # the time limit grows with the floor


def test_generation_is_the_same_in_another_process():
    indices = [0, 7, 123456]
    code = (
        "from cabinbench.layouts.family import generate\n"
        f"print(' '.join(generate('cabin_v1', i).content_hash for i in {indices}))"
    )
    other = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert other.stdout.split() == [generate("cabin_v1", i).content_hash for i in indices]


def test_the_hash_is_the_geometry_not_the_name_or_the_file(tmp_path):
    family = (families_dir() / "cabin_v1.yaml").read_text()
    copy = tmp_path / "renamed.yaml"
    copy.write_text(
        "# another family file, same numbers\n" + family.replace("description:", "description: Copy.")
    )
    assert generate(copy, 5).content_hash == generate("cabin_v1", 5, name="x/0001").content_hash
    assert generate("cabin_v1", 5).content_hash != generate("cabin_v1", 6).content_hash
    # the hash follows the geometry, the parameters that drew it do not matter
    layout = generate("cabin_v1", 5)
    text = "kind: cabin\ncabin: " + json.dumps(layout.parameters) + f"\nmax_steps: {layout.max_steps}\n"
    assert geometry_hash(parse_layout(text)) == layout.content_hash


@pytest.mark.parametrize(
    ("change", "field"),
    [
        (("seat_pitch: [0.76, 0.86]", "seat_pitch: [0.86, 0.76]"), "seat_pitch"),
        (("seed: 1801", "seed: 1801\nwings: 2"), "wings"),
        (("cells: [1, 4]", "cells: [0, 4]"), "cells[0]"),
        (("trolley: 0.2", "trolley: 2"), "clutter.trolley"),
        (
            ("{seats: [2, 2], width: [2.70, 2.90]}", "{seats: two, width: [2.70, 2.90]}"),
            "configurations[0].seats",
        ),
    ],
)
def test_a_broken_family_names_file_field_and_fix(tmp_path, change, field):
    path = tmp_path / "broken.yaml"
    path.write_text((families_dir() / "cabin_v1.yaml").read_text().replace(*change))
    with pytest.raises(LayoutError) as error:
        generate(path, 0)
    assert error.value.source == str(path) and error.value.field_name == field and error.value.fix


def test_the_cabin_kind_takes_exit_rows_aisle_widths_and_extra_obstacles():
    base = "kind: cabin\ncabin: {width: 4.8, seat_blocks: [2, 3, 2], rows: 4, seat_pitch: 0.8, "
    base += "seat_depth: 0.35, front_clearance: 1.0, "
    plain = parse_layout(base + "aisle_width: 0.5}")
    layout = parse_layout(
        base + "aisle_width: [0.5, 0.6], exit_rows: [2], exit_row_pitch: 1.1, obstacles: [[0, 0, 0.3, 0.2]]}"
    )
    assert layout.extent[2] == pytest.approx(plain.extent[2] + 0.3)
    assert len(layout.obstacles) == len(plain.obstacles) + 1
    with pytest.raises(LayoutError, match="cabin.obstacles"):
        parse_layout(base + "aisle_width: 0.5, obstacles: [[0, 0, 9, 0.2]]}")
    with pytest.raises(LayoutError, match="cabin.aisle_width"):
        parse_layout(base + "aisle_width: [0.5]}")


def test_suite_layout_names_load_everywhere_a_layout_name_does(capsys):
    name = "cabin-v1-test/0007"
    hash_ = get_suite("cabin-v1-test").content_hashes()[name]
    assert load_layout(name).content_hash == hash_
    assert gym.make("CabinBench/Coverage-v0", layout=name).unwrapped.layout.content_hash == hash_
    assert cabinbench.parallel_env(layout=name, n_agents=2).layout.content_hash == hash_
    assert complexity.main([name, "--json"]) == 0
    assert json.loads(capsys.readouterr().out)["layout"] == name
    for bad in ("cabin-v1-test/0100", "cabin-v9/0001", "classic/0000"):
        with pytest.raises(LayoutError):
            load_layout(bad)


def test_the_suites_command_lists_and_draws(tmp_path, capsys):
    assert suites.main(["--json"]) == 0
    listed = {row["name"]: row for row in json.loads(capsys.readouterr().out)}
    assert listed["cabin-v1-test"]["size"] == 100 and listed["cabin-v1-test"]["families"] == ["cabin_v1"]
    low, high = listed["cabin-v1-ood"]["complexity_total"]
    assert 0 < low < high
    assert suites.main(["--png", "classic", str(tmp_path / "sheet.png")]) == 0
    assert (tmp_path / "sheet.png").stat().st_size > 1000
    assert suites.main(["--png", "nosuch", str(tmp_path / "x.png")]) == 2
    assert "unknown suite" in capsys.readouterr().err


def test_run_suite_records_suite_start_and_time_limit(tmp_path, capsys):
    argv = ["--baseline", "random_bounce", "--suite", "cabin-v1-test", "--layouts", "2"]
    argv += ["--episodes-per-layout", "2", "--max-steps", "30", "--out", str(tmp_path / "random"), "--json"]
    assert run_main(argv) == 0
    summary = json.loads(capsys.readouterr().out)
    assert summary["suite"] == "cabin-v1-test" and summary["layouts"] == 2 and summary["episodes"] == 4
    records = read_records(tmp_path / "random")
    assert sorted(set(records["layout"])) == ["cabin-v1-test/0000", "cabin-v1-test/0001"]
    assert (records["suite"] == "cabin-v1-test").all()
    assert sorted(records["seed"] + records["episode"]) == [0, 1, 2, 3]  # every episode its own seed
    # the summary is the suite's: mean over layouts of per-layout means, stratified bootstrap interval
    cells = {("run", layout): group["coverage"].tolist() for layout, group in records.groupby("layout")}
    expected = stratified_bootstrap(cells)
    coverage = summary["metrics"]["coverage"]
    assert (coverage["mean"], coverage["ci_low"], coverage["ci_high"]) == pytest.approx(
        (expected.mean, expected.low, expected.high)
    )
    starts = np.array(records["start"].tolist())
    assert len({tuple(s) for s in starts}) == 4
    for (_, record), start in zip(records.iterrows(), starts):
        assert record["env_config"]["random_start"] and record["env_config"]["max_steps"] == 30
        layout = load_layout(record["layout"])
        assert layout.distance_to_walls(start[:2])[0] >= layout.robot.radius
        assert -math.pi <= start[2] <= math.pi

    fixed = argv[:-3] + ["--out", str(tmp_path / "fixed"), "--start", "fixed", "--layouts", "1"]
    assert run_main(fixed) == 0
    records = read_records(tmp_path / "fixed")
    assert all(start == list(load_layout("cabin-v1-test/0000").start) for start in records["start"])
    assert "random_start" not in records["env_config"][0]
    assert run_main(["--baseline", "random_bounce", "--suite", "cabin-v1-test", "--episodes", "2"]) == 2
    assert run_main(["--baseline", "random_bounce", "--layout", "a320_cell", "--layouts", "2"]) == 2


def test_suite_env_draws_a_layout_per_reset_from_its_seed():
    env = gym.make("CabinBench/Suite-v0", suite="cabin-v1-test").unwrapped
    drawn = {env.reset(seed=seed)[1]["layout"] for seed in range(8)}
    assert len(drawn) > 4 and drawn <= set(get_suite("cabin-v1-test").layout_names)
    shapes = set()
    for seed in (1, 2, 1):
        observation, info = env.reset(seed=seed)
        shapes.add(observation.shape)
        assert env.observation_space.contains(observation) and env.layout.name == info["layout"]
    assert shapes == {env.observation_space.shape}
    first, _ = gym.make("CabinBench/Suite-v0", suite="cabin-v1-test").reset(seed=1)
    np.testing.assert_array_equal(first, env.reset(seed=1)[0])
    few = gym.make("CabinBench/Suite-v0", suite="cabin-v1-ood", num_layouts=2).unwrapped
    assert {few.reset(seed=s)[1]["layout"] for s in range(6)} <= {"cabin-v1-ood/0000", "cabin-v1-ood/0001"}
    with pytest.raises(ValueError, match="num_layouts"):
        gym.make("CabinBench/Suite-v0", suite="cabin-v1-ood", num_layouts=51)


def test_random_team_starts_are_seeded_spread_and_free():
    layout = load_layout("cabin-v1-test/0003")
    spots = start_cell_spots(layout)
    poses = random_start_poses(layout, spots, 4, np.random.default_rng(3))
    np.testing.assert_array_equal(poses, random_start_poses(layout, spots, 4, np.random.default_rng(3)))
    gaps = [np.hypot(*(a[:2] - b[:2])) for i, a in enumerate(poses) for b in poses[i + 1 :]]
    assert min(gaps) >= layout.robot.tool_width + 0.05
    assert (layout.distance_to_walls(poses[:, :2]) >= layout.robot.radius).all()
    env = cabinbench.parallel_env(layout=layout, n_agents=4, random_start=True)
    _, infos = env.reset(seed=3)
    np.testing.assert_array_equal([infos[a]["pose"] for a in env.agents], poses)


def test_a_batched_env_on_a_suite_draws_its_layouts_as_suite_v0_does():
    """``BatchedCoverageEnv(suite=...)`` (what ``train --suite`` trains on): env ``i`` is a Suite-v0 env
    seeded ``seed + i``, so it plays the layouts Suite-v0 draws from that seed, a new one at each reset."""
    from cabinbench.envs.batched import BatchedCoverageEnv

    batched = BatchedCoverageEnv(num_envs=2, seed=5, suite="cabin-v1-test", max_steps=3)
    alone = gym.make("CabinBench/Suite-v0", suite="cabin-v1-test", max_steps=3).unwrapped
    assert batched.layout_names == ["cabin-v1-test"]
    for index in range(2):  # the first observations: Suite-v0's from the same seed
        np.testing.assert_array_equal(batched.observations[index], alone.reset(seed=5 + index)[0])
    played = [[env.layout.name] for env in batched.local.envs]
    for _ in range(4):  # every third step ends the episodes: each env draws its next layout
        for _ in range(3):
            batched.step(np.zeros((2, 2)))
        for index, env in enumerate(batched.local.envs):
            played[index].append(env.layout.name)
    for index in range(2):
        _, info = alone.reset(seed=5 + index)
        expected = [info["layout"]] + [alone.reset()[1]["layout"] for _ in range(4)]
        assert played[index] == expected and len(set(expected)) > 1
