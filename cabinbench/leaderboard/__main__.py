"""``python -m cabinbench.leaderboard``: the command lives in :mod:`cabinbench.commands.leaderboard`."""

from cabinbench.commands.leaderboard import main

if __name__ == "__main__":
    raise SystemExit(main())
