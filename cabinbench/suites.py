"""``python -m cabinbench.suites``: the command lives in :mod:`cabinbench.commands.suites`."""

from cabinbench.commands.suites import main

if __name__ == "__main__":
    raise SystemExit(main())
