"""``python -m cabinbench COMMAND ...``: the ``cabinbench`` console script."""

from cabinbench.commands import main

if __name__ == "__main__":
    raise SystemExit(main())
