"""``python -m cabinbench.bench``: the command lives in :mod:`cabinbench.commands.bench`."""

from cabinbench.commands.bench import main

if __name__ == "__main__":
    raise SystemExit(main())
