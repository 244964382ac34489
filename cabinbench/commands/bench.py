"""Throughput bench: ``python -m cabinbench.bench [--steps N] [--json]``.

Measures:

- single-env steps/s of ``CabinBench/Coverage-v0`` (64 rays, random actions, resets included) on
  ``a320_cell`` and ``full_cabin``, and on ``a320_cell`` with the 16 x 16 coverage patch the shipped
  policies observe, pinned to one core;
- the batched training env's agent-steps/s (needs torch; env stepping alone, random actions; best
  of 3), on one core and with ``num_workers`` = the machine's cores (this process steps one shard,
  a worker each other);
- the boustrophedon planner's time to plan ``full_cabin``;
- generating one cabin layout of each shipped family (mean over fresh indices), loading every
  layout of ``cabin-v1-test``, and the single env's steps/s on a generated layout
  (``cabin-v1-test/0007``, to set beside ``a320_cell``);
- seconds per training iteration of every learned baseline's default configuration and of the
  variants its trainer adds, on every core, split into env (the batched env's steps), rollout
  (collection, env included) and update (needs torch; a trainer offers this as ``bench_iteration``
  beside its ``main``), the ablations beside PPO alone;
- building maps of real size, drawn by :func:`cabinbench.layouts.building_maps.office_floor` as ROS map
  files: 50 m x 40 m (1000 x 800 px) and 100 m x 100 m (2000 x 2000 px) at 5 cm. For each: the time
  and peak memory (RSS) of a fresh process that loads it, its complexity's time, and the single
  env's steps/s on it; the boustrophedon plan (stopped after ``BIG_PLAN_LIMIT_S``): the 1000 x 800
  map in one piece, the 2000 x 2000 one bay by bay (``cells: auto``, the sequential protocol);
- peers stepped in the same run, so ratios survive machine drift: PettingZoo's Pistonball
  (pymunk physics, like ours; needs pygame) and Gymnasium's CartPole (pure-Python physics, a
  floor for per-step overhead).

Speed is stated by this command, never asserted by a test.
"""

from __future__ import annotations

import importlib
import json
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import gymnasium as gym
import numpy as np
import yaml

import cabinbench  # noqa: F401  (registers the envs)
from cabinbench.agents import EpisodeContext, baseline_class, load_baseline
from cabinbench.cli import ArgumentParser, non_negative_int, positive_int, user_errors
from cabinbench.commands.train import trainable_baselines
from cabinbench.layouts.building_maps import office_floor, write_building
from cabinbench.layouts.complexity import layout_complexity
from cabinbench.layouts.resolve import load_layout

# metres (at 5 cm a pixel), and how the boustrophedon plans the map: in one piece, or bay by bay (in one
# piece the 2000 x 2000 map's route tables need more memory than this machine has, and are refused)
BIG_MAPS = {"map_1000x800": ((50.0, 40.0), "whole"), "map_2000x2000": ((100.0, 100.0), "bays")}
# A fresh process loads a map and reports its seconds and peak memory (RSS, GB; the interpreter and
# imports, about 0.1 GB, included).
LOAD_IN_FRESH_PROCESS = """
import resource, sys, time
from cabinbench.layouts.resolve import load_layout
started = time.perf_counter()
load_layout(sys.argv[1]).coverable_raster
print(time.perf_counter() - started, resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 2**20)
"""
PLAN_IN_FRESH_PROCESS = (
    "import sys; from cabinbench.commands.bench import bench_planner; "
    "print(bench_planner(sys.argv[1], repeats=1))"
)
BIG_PLAN_LIMIT_S = 300  # a plan still running then is reported as not done, and the bench goes on


def steps_per_second(env, steps: int, seed: int = 0) -> float:
    """Random-action steps per second of a Gymnasium env, resets included."""
    env.action_space.seed(seed)
    actions = [env.action_space.sample() for _ in range(steps)]  # drawn before timing

    def run(actions) -> None:
        env.reset(seed=seed)
        for action in actions:
            *_, terminated, truncated, _ = env.step(action)
            if terminated or truncated:
                env.reset()

    run(actions[: min(200, steps)])  # warm-up: numba caches, allocator
    started = time.perf_counter()
    run(actions)
    return steps / (time.perf_counter() - started)


def bench_single(layout: str, steps: int, **env_kwargs) -> float:
    return steps_per_second(gym.make("CabinBench/Coverage-v0", layout=layout, n_rays=64, **env_kwargs), steps)


def bench_batched(layout: str, num_envs: int, steps: int, num_workers: int, repeats: int = 3) -> float | None:
    """Agent-steps/s of the batched env: the best of ``repeats`` runs of ``steps`` steps (on a
    shared machine the slower runs measure the neighbours, not the env); None without torch."""
    try:
        import torch
    except ImportError:
        return None

    from cabinbench.envs.batched import BatchedCoverageEnv

    generator = torch.Generator().manual_seed(0)
    actions = torch.rand((steps, num_envs, 2), generator=generator) * 2 - 1
    with BatchedCoverageEnv(layout, num_envs=num_envs, seed=0, num_workers=num_workers) as env:
        for action in actions[:5]:
            env.step(action)
        timings = []
        for _ in range(repeats):
            started = time.perf_counter()
            for action in actions:
                env.step(action)
            timings.append(time.perf_counter() - started)
        return steps * num_envs / min(timings)


def bench_planner(layout: str, baseline: str = "boustrophedon", repeats: int = 3) -> float:
    """Seconds a planning baseline (found by name in the registry) takes to plan a layout: its
    ``reset``, best of ``repeats`` after a warm-up (none for a single repeat)."""
    loaded = load_layout(layout)
    planner = load_baseline(baseline)
    env = gym.make("CabinBench/Coverage-v0", layout=loaded)
    observation, info = env.reset(seed=0)
    context = EpisodeContext(
        loaded, "sequential", seed=0, observation_layout=env.unwrapped.observation_layout
    )
    if repeats > 1:
        planner.reset(context, observation, info)  # warm-up
    timings = []
    for _ in range(repeats):
        started = time.perf_counter()
        planner.reset(context, observation, info)
        timings.append(time.perf_counter() - started)
    return min(timings)


def bench_training(iterations: int) -> dict[str, dict[str, float]]:
    """``{baseline: {"env", "rollout", "update", "total": seconds per iteration}}`` from every trainer
    of a registered baseline that offers ``bench_iteration`` ({} without torch or with 0 iterations)."""
    try:
        import torch  # noqa: F401
    except ImportError:
        return {}
    trainers = (
        {baseline_class(name).trainer.split(":")[0] for name in trainable_baselines()} if iterations else ()
    )
    figures = {}
    for module in sorted(trainers):
        measure = getattr(importlib.import_module(module), "bench_iteration", None)
        if measure is not None:
            figures.update(measure(iterations))
    return figures


def bench_big_map(name: str, size: tuple[float, float], folder: Path, steps: int, plan: str) -> dict:
    """Load (s, peak GB), complexity (s), single-env steps/s and the plan (s) of a drawn map, the plan
    in one piece (``plan`` "whole") or bay by bay ("bays")."""
    path = write_building(folder, name, office_floor(*size))
    loaded = subprocess.run(
        [sys.executable, "-c", LOAD_IN_FRESH_PROCESS, str(path)], capture_output=True, text=True, check=True
    )
    load_s, load_gb = (float(value) for value in loaded.stdout.split())
    layout = load_layout(path)
    started = time.perf_counter()
    layout_complexity(layout)
    results = {
        f"{name}_load_s": load_s,
        f"{name}_load_peak_gb": load_gb,
        f"{name}_complexity_s": time.perf_counter() - started,
        f"single_{name}_steps_per_s": bench_single(str(path), steps),
    }
    planned_path, key = path, f"boustrophedon_plan_{name}_s"
    if plan == "bays":
        planned_path, key = folder / f"{name}_bays.yaml", f"boustrophedon_plan_{name}_bays_s"
        spec = {"kind": "occupancy", "occupancy": yaml.safe_load(path.read_text()), "cells": "auto"}
        planned_path.write_text(yaml.safe_dump(spec))
    # in a process of its own, stopped after BIG_PLAN_LIMIT_S: None when not done by then
    try:
        planned = subprocess.run(
            [sys.executable, "-c", PLAN_IN_FRESH_PROCESS, str(planned_path)],
            capture_output=True,
            text=True,
            check=True,
            timeout=BIG_PLAN_LIMIT_S,
        )
        results[key] = float(planned.stdout)
    except subprocess.TimeoutExpired:
        results[key] = None
    return results


def bench_pistonball(steps: int) -> float | None:
    """Agent-steps/s of PettingZoo's Pistonball (pymunk), or None without pygame."""
    os.environ.setdefault("SDL_VIDEODRIVER", "dummy")
    try:
        from pettingzoo.butterfly import pistonball_v6
    except ImportError:
        return None
    env = pistonball_v6.parallel_env(continuous=True)
    env.reset(seed=0)
    rng = np.random.default_rng(0)
    agent_steps, started = 0, time.perf_counter()
    for _ in range(steps):
        actions = {agent: rng.uniform(-1, 1, (1,)).astype(np.float32) for agent in env.agents}
        env.step(actions)
        agent_steps += len(actions)
        if not env.agents:
            env.reset()
    return agent_steps / (time.perf_counter() - started)


def bench_generation(family: str, count: int = 20) -> float:
    """Mean seconds to generate one layout of ``family``, at indices no suite draws (so none is cached)."""
    from cabinbench.layouts.family import generate, load_family

    loaded = load_family(family)
    started = time.perf_counter()
    for index in range(10**6, 10**6 + count):
        generate(loaded, index)
    return (time.perf_counter() - started) / count


def bench_suite_load(suite: str) -> float:
    """Seconds to load every layout of ``suite`` by name, as a run or a user does."""
    from cabinbench.layouts.suites import get_suite

    started = time.perf_counter()
    for name in get_suite(suite).layout_names:
        load_layout(name)
    return time.perf_counter() - started


def parse_args(argv: list[str] | None):
    parser = ArgumentParser(
        prog="python -m cabinbench.bench", description="Env throughput, beside peer envs."
    )
    parser.add_argument("--steps", type=positive_int, default=20000, help="single-env steps per measurement")
    parser.add_argument("--num-envs", type=positive_int, default=256, help="envs in the batched env")
    parser.add_argument(
        "--training-iterations",
        type=non_negative_int,
        default=3,
        help="timed training iterations per learned baseline, after one warm-up (0: none)",
    )
    parser.add_argument("--json", action="store_true", help="print one JSON object")
    return parser.parse_args(argv)


def measure_envs(args, cores: list[int]) -> dict:
    """Every figure but training's: the batched env on all ``cores``, the rest on the first alone."""
    batched_steps = max(10, args.steps // args.num_envs)
    all_cores = bench_batched("a320_cell", args.num_envs, batched_steps, num_workers=len(cores))
    if hasattr(os, "sched_setaffinity"):
        os.sched_setaffinity(0, {cores[0]})  # one core from here on, as the single-env target says
    maps = {}
    with tempfile.TemporaryDirectory() as folder:
        for name, (size, plan) in BIG_MAPS.items():
            maps.update(bench_big_map(name, size, Path(folder), args.steps, plan))
    results = {
        "single_a320_cell_steps_per_s": bench_single("a320_cell", args.steps),
        "single_full_cabin_steps_per_s": bench_single("full_cabin", args.steps),
        "single_a320_cell_patch16_steps_per_s": bench_single("a320_cell", args.steps, coverage_patch=16),
        "batched_a320_cell_agent_steps_per_s_one_core": bench_batched(
            "a320_cell", args.num_envs, batched_steps, num_workers=1
        ),
        f"batched_a320_cell_agent_steps_per_s_{len(cores)}_workers": all_cores,
        "boustrophedon_plan_full_cabin_s": bench_planner("full_cabin"),
        "generate_cabin_v1_layout_s": bench_generation("cabin_v1"),
        "generate_cabin_v1_ood_layout_s": bench_generation("cabin_v1_ood"),
        "load_cabin_v1_test_s": bench_suite_load("cabin-v1-test"),
        "single_cabin_v1_test_0007_steps_per_s": bench_single("cabin-v1-test/0007", args.steps),
        **maps,
        "peer_cartpole_steps_per_s": steps_per_second(gym.make("CartPole-v1"), args.steps),
        "peer_pistonball_agent_steps_per_s": bench_pistonball(max(50, args.steps // 200)),
    }
    if hasattr(os, "sched_setaffinity"):
        os.sched_setaffinity(0, set(cores))  # training uses every core (env workers, shaping threads)
    return results


def add_training(results: dict, iterations: int) -> None:
    """Seconds per training iteration of every learned baseline, and each one's ratio to PPO's."""
    training = bench_training(iterations)
    for baseline, seconds in training.items():
        for part, value in seconds.items():
            results[f"train_{baseline}_{part}_s_per_iteration"] = value
    if "ppo" in training:  # what curiosity and imitation add to PPO's iteration, measured in this run
        for baseline, seconds in training.items():
            results[f"ratio_train_{baseline}_to_ppo"] = seconds["total"] / training["ppo"]["total"]


def add_ratios(results: dict, workers: int) -> None:
    """What batching buys per core, what the other cores add, and our single env against the peers."""
    one_core = results["batched_a320_cell_agent_steps_per_s_one_core"]
    if one_core:
        results["ratio_batched_one_core_to_single"] = one_core / results["single_a320_cell_steps_per_s"]
        all_cores = results[f"batched_a320_cell_agent_steps_per_s_{workers}_workers"]
        results[f"ratio_batched_{workers}_workers_to_one"] = all_cores / one_core
    cartpole = results["peer_cartpole_steps_per_s"]
    pistonball = results["peer_pistonball_agent_steps_per_s"]
    results["ratio_a320_cell_to_cartpole"] = results["single_a320_cell_steps_per_s"] / cartpole
    if pistonball:
        results["ratio_a320_cell_to_pistonball"] = results["single_a320_cell_steps_per_s"] / pistonball


def print_table(results: dict, workers: int) -> None:
    """One line per figure, with its target where it has one."""
    targets = {
        "single_a320_cell_steps_per_s": "target >= 10,000",
        f"batched_a320_cell_agent_steps_per_s_{workers}_workers": "target >= 50,000 on this machine",
        "ratio_batched_one_core_to_single": "target >= 3",
        f"ratio_batched_{workers}_workers_to_one": "target >= 1.8",
        "boustrophedon_plan_full_cabin_s": "target < 1 s",
        "generate_cabin_v1_layout_s": "target <= 0.05 s",
        "generate_cabin_v1_ood_layout_s": "target <= 0.05 s",
        "load_cabin_v1_test_s": "target <= 5 s",
        "single_cabin_v1_test_0007_steps_per_s": "target: as a320_cell",
        "train_ppo_gail_total_s_per_iteration": "target <= 0.6 s; not met: the defaults, kept",
        **{
            f"train_ppo_gail_{candidate}_total_s_per_iteration": "not adopted (docs/experiments.md)"
            for candidate in ("shaping_epochs_1", "small_icm", "coarse_patch")
        },
        "train_ppo_gail_cheaper_total_s_per_iteration": "not adopted: below the defaults on cabin-v1-val",
        "map_1000x800_load_s": "target <= 5 s",
        "map_1000x800_load_peak_gb": "target <= 1 GB",
        "map_2000x2000_load_s": "target <= 20 s",
        "map_2000x2000_load_peak_gb": "target <= 4 GB",
        "map_1000x800_complexity_s": "target <= 2 s",
        "map_2000x2000_complexity_s": "target <= 2 s",
        "single_map_1000x800_steps_per_s": "target >= 5,000",
        "single_map_2000x2000_steps_per_s": "target >= 5,000",
        "boustrophedon_plan_map_1000x800_s": f"target <= 10 s (stopped after {BIG_PLAN_LIMIT_S} s)",
        "boustrophedon_plan_map_2000x2000_bays_s": f"bay by bay (stopped after {BIG_PLAN_LIMIT_S} s)",
    }
    for name, value in results.items():
        unmeasured = (
            "not done in time" if name.startswith("boustrophedon_plan_map") else "not in this install"
        )
        shown = unmeasured if value is None else f"{value:,.4g}" if value < 100 else f"{value:,.0f}"
        print(f"{name:<50} {shown:>16}   {targets.get(name, '')}")


@user_errors
def main(argv: list[str] | None = None) -> int:
    args = parse_args(argv)
    cores = sorted(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else [0]
    results = measure_envs(args, cores)
    add_training(results, args.training_iterations)
    add_ratios(results, len(cores))
    if args.json:
        print(json.dumps({k: (round(v, 4) if isinstance(v, float) else v) for k, v in results.items()}))
    else:
        print_table(results, len(cores))
    return 0
