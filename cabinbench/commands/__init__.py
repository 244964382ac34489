"""Every command line of cabinbench, one module each; the library never imports them.

``cabinbench COMMAND ...`` (the console script) and ``python -m cabinbench.COMMAND ...`` run the
same ``main``.
"""

from __future__ import annotations

import importlib
import sys

COMMANDS = {
    "run": "run a baseline on a layout or a suite and record every episode",
    "train": "train a learned baseline",
    "leaderboard": "regenerate the leaderboard, build the site, file or verify a submission",
    "paper": "regenerate the paper from the results",
    "layouts": "list the layouts, or export one as a ROS map",
    "suites": "list the suites, draw or verify one",
    "complexity": "navigation complexity of a layout",
    "building_maps": "redraw the building maps",
    "bench": "measure the envs' and the trainers' speed",
}


def main(argv: list[str] | None = None) -> int:
    """``cabinbench COMMAND [ARGS]``: hand ARGS to ``cabinbench.commands.COMMAND.main``."""
    argv = sys.argv[1:] if argv is None else list(argv)
    if not argv or argv[0] in ("-h", "--help"):
        width = max(map(len, COMMANDS))
        listing = "\n".join(f"  {name:<{width}}  {what}" for name, what in COMMANDS.items())
        print(f"usage: cabinbench COMMAND [ARGS] (cabinbench COMMAND --help)\n\ncommands:\n{listing}")
        return 0 if argv else 2
    command, *rest = argv
    if command not in COMMANDS:
        print(f"cabinbench: unknown command {command!r}; one of {', '.join(COMMANDS)}", file=sys.stderr)
        return 2
    return importlib.import_module(f"cabinbench.commands.{command}").main(rest)
