"""``python -m cabinbench.paper``: the command lives in :mod:`cabinbench.commands.paper`."""

from cabinbench.commands.paper import main

if __name__ == "__main__":
    raise SystemExit(main())
