"""``python -m cabinbench.run``: the command lives in :mod:`cabinbench.commands.run`."""

from cabinbench.commands.run import main

if __name__ == "__main__":
    raise SystemExit(main())
