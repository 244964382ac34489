"""Single-robot coverage env over a whole suite (Gymnasium): a new layout at every reset.

## Description

The env of :mod:`cabinbench.envs.coverage_env`, except that each reset draws one layout of a
suite (:mod:`cabinbench.suites`) from the reset's seeded generator, so that a learner trains on a
family of cabins rather than on one map (Procgen's ``num_levels`` idea: ``num_layouts`` keeps
only the first N layouts). Made by ``gymnasium.make("CabinBench/Suite-v0", suite="cabin-v1-train")``.
The layout in play is ``env.unwrapped.layout``; the reset's info names it (``layout``).

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
argument of ``CoverageEnv`` but ``layout``; ``random_start`` defaults to ``True``.
"""

from __future__ import annotations

import gymnasium as gym

from cabinbench.envs.coverage_env import CoverageEnv
from cabinbench.layouts.suites import get_suite
from cabinbench.values import is_whole_number


class SuiteEnv(CoverageEnv):
    def __init__(
        self,
        suite: str = "cabin-v1-train",
        num_layouts: int | None = None,
        random_start: bool = True,
        **kwargs,
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
        super().__init__(self.suite.layout(names[0]), random_start=random_start, **kwargs)

    def reset(self, *, seed: int | None = None, options: dict | None = None):
        gym.Env.reset(self, seed=seed)  # seeds the generator that draws the layout, then the start
        name = self.layout_names[int(self.np_random.integers(len(self.layout_names)))]
        if name != self.layout.name:
            self.use_layout(self.suite.layout(name))
        observation, info = super().reset(options=options)
        return observation, {**info, "layout": name}
