"""``third_party``: coverage planners from the package registries, driven through the ``path`` baseline.

- ``coverage_path_planner``: :class:`CoveragePathPlanner`, the C++ Complete Coverage Path Planner of
  the PyPI package ``coverage-path-planner`` (``pip install cabinbench[thirdparty]``).
"""

from cabinbench.baselines.third_party.coverage_path_planner import CoveragePathPlanner

__all__ = ["CoveragePathPlanner"]
