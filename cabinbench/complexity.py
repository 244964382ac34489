"""``python -m cabinbench.complexity``: the command lives in :mod:`cabinbench.commands.complexity`."""

from cabinbench.commands.complexity import main

if __name__ == "__main__":
    raise SystemExit(main())
