"""Coverage envs over a whole suite, a new layout at every reset: :class:`SuiteEnv` (Gymnasium) and
:class:`TeamSuiteEnv` (its core, K robots)."""

from __future__ import annotations

import numpy as np

from cabinbench.envs.coverage_env import CoreAttribute, CoverageEnv
from cabinbench.envs.settings import EnvSettings
from cabinbench.envs.team_env import TeamCoverageEnv
from cabinbench.layouts.suites import get_suite
from cabinbench.values import is_whole_number

SUITE_SETTINGS = EnvSettings(random_start=True)
"""The settings a suite env starts from: random starts, the evaluation protocol of the suites."""


class TeamSuiteEnv(TeamCoverageEnv):
    """The team env on a suite: each reset draws one of the suite's first ``num_layouts`` layouts
    from the reset's generator, before the start poses. Settings not given are
    :data:`SUITE_SETTINGS`'s (``random_start``). ``state_space`` is the first layout's (its
    size grows with the layout's goal markers: a centralised critic needs one layout family)."""

    def __init__(
        self,
        suite: str = "cabin-v1-train",
        num_layouts: int | None = None,
        n_agents: int = 1,
        settings: EnvSettings | None = None,
        **overrides,
    ):
        self.suite = get_suite(suite)
        names = self.suite.layout_names
        if num_layouts is not None:
            if not (is_whole_number(num_layouts) and 1 <= num_layouts <= len(names)):
                raise ValueError(
                    f"num_layouts must be 1 to {len(names)} for suite {suite}, got {num_layouts!r}"
                )
            names = names[:num_layouts]
        self.layout_names = names
        super().__init__(self.suite.layout(names[0]), n_agents, settings or SUITE_SETTINGS, **overrides)

    def begin_episode(self, seed: int | None = None) -> None:
        self.seed_generator(seed)  # the layout is drawn first, then the start poses
        name = self.layout_names[int(self.np_random.integers(len(self.layout_names)))]
        if name != self.layout.name:
            self.use_layout(self.suite.layout(name))
        super().begin_episode()

    def agent_infos(self) -> dict:
        name = np.str_(self.layout.name)
        return {agent: {**info, "layout": name} for agent, info in super().agent_infos().items()}


class SuiteEnv(CoverageEnv):
    """Single-robot coverage env over a whole suite (Gymnasium): a new layout at every reset.

    ## Description

    The env of :mod:`cabinbench.envs.coverage_env`, except that each reset draws one layout of a
    suite (:mod:`cabinbench.suites`) from the reset's seeded generator, so that a learner trains on a
    family of cabins rather than on one map (Procgen's ``num_levels`` idea: ``num_layouts`` keeps
    only the first N layouts). Made by ``gymnasium.make("CabinBench/Suite-v0", suite="cabin-v1-train")``.
    The layout in play is ``env.unwrapped.layout``; every info names it (``layout``, a numpy string).
    :class:`TeamSuiteEnv` is the same for a team of K robots (PettingZoo), the core this env wraps.

    ## Action Space

    ``Box(-1, 1, (2,), float32)``: (linear, angular), as in ``CoverageEnv``.

    ## Observation Space

    ``Box(float32, (6 * n_rays + coverage_patch² + 2,))``, laid out as in ``CoverageEnv``
    (``env.unwrapped.observation_layout``). Its shape depends only on the arguments, never on the
    layout drawn: every layout of the suite fits one policy.

    ## Rewards

    The preset named by ``reward``, as in ``CoverageEnv``.

    ## Starting State

    A layout drawn uniformly from the suite's first ``num_layouts`` layouts, then (with
    ``random_start``, the default: the evaluation protocol of the suites) a pose drawn from the same
    generator in the layout's start cell, with a uniform heading; without it the layout's own start.

    ## Episode End

    As in ``CoverageEnv``; the step limit is ``max_steps`` or, by default, the drawn layout's own
    (scaled with its coverable area).

    ## Arguments

    ``suite`` (a suite name, default ``"cabin-v1-train"``), ``num_layouts`` (default: all), and every
    argument of ``CoverageEnv`` but ``layout`` (the settings of
    :class:`~cabinbench.envs.settings.EnvSettings`); ``random_start`` defaults to ``True``
    (:data:`SUITE_SETTINGS`).
    """

    def __init__(
        self,
        suite: str = "cabin-v1-train",
        num_layouts: int | None = None,
        settings: EnvSettings | None = None,
        **overrides,
    ):
        self._wrap(TeamSuiteEnv(suite, num_layouts, 1, settings, **overrides))

    suite = CoreAttribute()
    layout_names = CoreAttribute()
