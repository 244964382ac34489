"""``python -m cabinbench.building_maps``: the command lives in :mod:`cabinbench.commands.building_maps`."""

from cabinbench.commands.building_maps import main

if __name__ == "__main__":
    raise SystemExit(main())
