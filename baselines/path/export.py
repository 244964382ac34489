"""Paths out: a planner baseline's plan written as CSV, ``nav_msgs/Path`` YAML or GeoJSON.

    export_plan("boustrophedon", "a320_cell", "plan.csv")

A planner baseline (``boustrophedon``, or any whose ``reset`` leaves its plan in ``legs``, a list of
:class:`~cabinbench.baselines.boustrophedon.Leg`) is reset exactly as ``run`` resets it for the
episode of that seed, and each robot's legs, joined in driving order, are written as its path. Run
back as ``--baseline path``, a single robot's exported plan drives the planner's episode again:
the same waypoints through the same follower. What a file cannot hold is a leg's start condition;
a team's convoy gates (wait for a cell to clear, then a delay) are lost, so a team's paths start
at once.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
from cabinbench.baselines.path.formats import path_format, write_paths

from cabinbench.agents import EpisodeContext, load_baseline
from cabinbench.episodes import make_env
from cabinbench.errors import BaselineError
from cabinbench.layouts.model import Layout
from cabinbench.layouts.resolve import load_layout


def planned_paths(
    baseline_name: str,
    layout: str | Layout,
    n_agents: int = 1,
    seed: int = 0,
    protocol: str = "sequential",
    random_start: bool = False,
    config: dict | None = None,
) -> list[np.ndarray]:
    """One (N, 2) path per robot: the plan ``baseline_name`` makes in ``reset`` for the episode of
    ``seed`` (its start pose: the layout's, or with ``random_start`` the one drawn from ``seed``)."""
    layout = layout if isinstance(layout, Layout) else load_layout(layout)
    baselines = [load_baseline(baseline_name, **(config or {})) for _ in range(n_agents)]
    env_kwargs = {**baselines[0].env_options, **({"random_start": True} if random_start else {})}
    env = make_env(layout, protocol, n_agents, env_kwargs)
    try:
        observations, infos = env.reset(seed=seed)
        paths = []
        for index, (agent, baseline) in enumerate(zip(list(env.agents), baselines)):
            context = EpisodeContext(
                layout, protocol, seed, index, n_agents, env_kwargs, env.unwrapped.observation_layout
            )
            baseline.reset(context, observations[agent], infos[agent])
            legs = getattr(baseline, "legs", None)
            if not legs:
                raise BaselineError(
                    f"baseline {baseline_name!r} has no plan to export (robot {index}); a planner "
                    "baseline leaves its plan in `legs` when reset, as boustrophedon does"
                )
            paths.append(np.vstack([leg.waypoints for leg in legs]))
    finally:
        env.close()
    return paths


def export_plan(
    baseline_name: str,
    layout: str | Layout,
    file: str | Path,
    n_agents: int = 1,
    seed: int = 0,
    protocol: str = "sequential",
    random_start: bool = False,
    config: dict | None = None,
) -> Path:
    """Write the plan of ``baseline_name`` (made with ``config``) on ``layout`` (see
    :func:`planned_paths`) to ``file``: ``.csv`` or ``.yaml`` (nav_msgs/Path) for one robot,
    ``.geojson`` for one or a team. Returns the path written."""
    kind = path_format(file)  # an unknown suffix is refused before planning
    if kind != "geojson" and n_agents > 1:
        raise BaselineError(
            f"{file}: a {kind} file holds one robot's path; write a team's to a .geojson file"
        )
    paths = planned_paths(baseline_name, layout, n_agents, seed, protocol, random_start, config)
    name = layout if isinstance(layout, str) else layout.name
    return write_paths(file, paths, f"{baseline_name} plan of {name}")
