"""The envs: one robot (Gymnasium, :mod:`.coverage_env`) and a team (PettingZoo, :mod:`.team_env`)."""
