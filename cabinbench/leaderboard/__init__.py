"""The leaderboard built from recorded runs: tables, statistics views, figures, the static site
and submissions (``python -m cabinbench.leaderboard``, :mod:`cabinbench.commands.leaderboard`)."""
