"""``python -m cabinbench.train``: the command lives in :mod:`cabinbench.commands.train`."""

from cabinbench.commands.train import main

if __name__ == "__main__":
    raise SystemExit(main())
