"""The envs: single-robot Gymnasium (:mod:`.coverage_env`)."""
