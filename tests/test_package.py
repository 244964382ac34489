"""The package as users install and extend it: one import name, baselines found by entry point, a
core that runs without torch, and a core that never imports a baseline."""

import ast
import json
import os
import subprocess
import sys
import textwrap
from pathlib import Path

import cabinbench
from cabinbench.agents import load_baseline, registered_baselines
from cabinbench.errors import BaselineError

from .plugin import install_spinner

CORE = Path(cabinbench.__file__).resolve().parent
BUILT_IN = {"random_bounce", "boustrophedon", "ppo_gail", "ppo", "ppo_icm", "ppo_gail_only"}


def run_python(args: list[str], env_extra: dict | None = None, cwd=None) -> subprocess.CompletedProcess:
    env = {**os.environ, **(env_extra or {})}
    return subprocess.run(
        [sys.executable, *args], capture_output=True, text=True, timeout=300, env=env, cwd=cwd
    )


def test_every_built_in_baseline_is_registered_as_an_entry_point_and_loads():
    assert BUILT_IN <= set(registered_baselines())
    for name in BUILT_IN:
        assert load_baseline(name).name == name


def test_an_unknown_baseline_names_the_registered_ones():
    try:
        load_baseline("nope")
    except BaselineError as error:
        assert all(name in str(error) for name in BUILT_IN)
    else:
        raise AssertionError("an unknown baseline loaded")


def test_a_third_party_package_adds_a_baseline_through_its_entry_point(tmp_path):
    """A package that declares ``spinner = "spinner_pkg:Spinner"`` in the entry-point group
    ``cabinbench.baselines`` runs as ``run --baseline spinner`` with no edit to cabinbench. The package is
    installed the way pip leaves it: its module and a dist-info folder with entry_points.txt, on sys.path."""
    site = install_spinner(tmp_path / "site")
    out = tmp_path / "runs"
    args = ["-m", "cabinbench.run", "--baseline", "spinner", "--layout", "a320_cell", "--episodes", "1"]
    completed = run_python(
        [*args, "--max-steps", "20", "--json", "--out", str(out)], {"PYTHONPATH": str(site)}, cwd=tmp_path
    )
    assert completed.returncode == 0, completed.stderr
    summary = json.loads(completed.stdout)
    [record] = [json.loads(line) for line in Path(summary["records"]).read_text().splitlines()]
    assert record["baseline"] == "spinner" and record["steps"] == 20
    assert record["path_length"] < 0.05  # it turned on the spot
    assert record["rotation"] > 1.0


def test_import_and_an_episode_of_each_env_need_no_torch():
    code = textwrap.dedent(
        """
        import sys
        import gymnasium as gym
        import cabinbench
        env = gym.make("CabinBench/A320Cell-v0")
        env.reset(seed=0)
        for _ in range(30):
            env.step(env.action_space.sample())
        team = cabinbench.parallel_env(layout="full_cabin", n_agents=2)
        team.reset(seed=0)
        for _ in range(30):
            team.step({agent: team.action_space(agent).sample() for agent in team.agents})
        assert "torch" not in sys.modules, "torch was imported"
        """
    )
    completed = run_python(["-c", code])
    assert completed.returncode == 0, completed.stderr


def test_no_core_module_imports_a_baseline():
    """The core finds baselines through the registry only (cabinbench.agents)."""
    offenders = []
    for path in sorted(CORE.rglob("*.py")):
        relative = path.relative_to(CORE)
        if relative.parts[0] == "baselines":
            continue
        for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
            if isinstance(node, ast.ImportFrom):
                names = [node.module or ""] if node.level == 0 else [f"{'.' * node.level}{node.module or ''}"]
                names += [f"{names[0]}.{alias.name}" for alias in node.names]
            elif isinstance(node, ast.Import):
                names = [alias.name for alias in node.names]
            else:
                continue
            if any(name.startswith(("baselines", "cabinbench.baselines", ".baselines")) for name in names):
                offenders.append(f"{relative}:{node.lineno}")
    assert not offenders, f"core modules import a baseline: {offenders}"
