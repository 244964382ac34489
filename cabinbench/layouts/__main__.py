"""``python -m cabinbench.layouts``: the command lives in :mod:`cabinbench.commands.layouts`."""

from cabinbench.commands.layouts import main

if __name__ == "__main__":
    raise SystemExit(main())
