"""cabinbench: complete coverage path planning benchmark for cleaning robots in airline cabins.

Importing the package registers the Gymnasium ids: one per built-in layout
(``CabinBench/A320Cell-v0`` ...), the generic ``CabinBench/Coverage-v0`` that takes
``layout=`` (a name, a suite layout name such as ``cabin-v1-test/0007``, or a YAML path), and
``CabinBench/Suite-v0`` that takes ``suite=`` and plays a layout of it per reset. A process
that never imports cabinbench makes them as
``gymnasium.make("cabinbench:CabinBench/A320Cell-v0")`` (Gymnasium imports the module first).
"""

import gymnasium

from cabinbench.errors import LayoutError
from cabinbench.layouts.load import available_layouts, builtin_layout_dir
from cabinbench.layouts.model import Layout
from cabinbench.layouts.resolve import load_layout
from cabinbench.version import __version__

ENTRY_POINT = "cabinbench.envs.coverage_env:CoverageEnv"


def gym_id(layout_name: str) -> str:
    """``a320_cell`` → ``CabinBench/A320Cell-v0``."""
    return "CabinBench/" + "".join(part[:1].upper() + part[1:] for part in layout_name.split("_")) + "-v0"


def _register() -> None:
    builtin = sorted(path.stem for path in builtin_layout_dir().glob("*.yaml"))
    for name in builtin:
        if gym_id(name) not in gymnasium.registry:
            gymnasium.register(gym_id(name), entry_point=ENTRY_POINT, kwargs={"layout": name})
    if "CabinBench/Coverage-v0" not in gymnasium.registry:
        gymnasium.register("CabinBench/Coverage-v0", entry_point=ENTRY_POINT)
    if "CabinBench/Suite-v0" not in gymnasium.registry:
        gymnasium.register("CabinBench/Suite-v0", entry_point="cabinbench.envs.suite_env:SuiteEnv")


_register()


def parallel_env(**kwargs):
    """The multi-robot PettingZoo ``ParallelEnv`` (:class:`cabinbench.envs.team_env.TeamCoverageEnv`)."""
    from cabinbench.envs.team_env import TeamCoverageEnv  # lazy: plain Gymnasium users need no PettingZoo

    return TeamCoverageEnv(**kwargs)


def env(**kwargs):
    """The same multi-robot env in PettingZoo's AEC form (``parallel_to_aec`` of :func:`parallel_env`)."""
    from pettingzoo.utils.conversions import parallel_to_aec

    return parallel_to_aec(parallel_env(**kwargs))


__all__ = [
    "Layout",
    "LayoutError",
    "__version__",
    "available_layouts",
    "env",
    "gym_id",
    "load_layout",
    "parallel_env",
]
