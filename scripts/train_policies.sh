#!/usr/bin/env bash
# Train every learned policy the committed results use, with the default training config, as one Ray sweep: the
# four ablations, each at its checkpoint with the best headline score on cabin-v1-val (--export best), at seed 0
# (fixed in advance; installed with --ship, the leaderboard's policies) and at seeds 1 to 4 (kept with
# --keep, the ablation table's). Training is deterministic on a CPU, whatever the cores a run is given (tested);
# its runs, swept a few at a time, reproduced the four shipped policies exactly (docs/experiments.md).
# Usage: [BASELINES="ppo ..."] bash scripts/train_policies.sh [SEED ...]   (from the repository root; default: the
# four ablations, seeds 0 1 2 3 4), then bash scripts/make_results.sh learned [BASELINE ...] to score them.
# The runs are Ray tasks, one CPU each: on a Ray instance of this machine started for the sweep, or on the cluster
# at $RAY_ADDRESS (e.g. auto, after `ray start --head` here and `ray start --address=HEAD:6379` on each other node;
# the repository folder must be shared between them). An interrupted sweep continues with
# RESUME=1 bash scripts/train_policies.sh: each unfinished run resumes from its latest checkpoint and trains
# exactly what it would have trained uninterrupted. The run folders live in results/training_runs/, so that a
# sweep that outlasts a sitting commits its finished runs as it goes: git ignores what a finished run no longer
# needs (checkpoints, demonstrations), and a finished run resumes as finished without them. TRAIN_OPTIONS
# adds options to every run (e.g. "--iterations 2 --validation-episodes 1" for a smoke run: it ships what it trains).
set -euo pipefail
seeds=${*:-0 1 2 3 4}
runs=results/training_runs/train_policies  # this script's own run folders
baselines=${BASELINES:-ppo_gail ppo ppo_icm ppo_gail_only}
if [ "${RESUME:-0}" = 1 ]; then resume=--resume; else
  resume=""
  for baseline in $baselines; do rm -rf "$runs/${baseline}__seed"*; done
fi
started=$(date +%s)
# shellcheck disable=SC2086  # $baselines, $seeds, $resume and $TRAIN_OPTIONS are word lists
python -m cabinbench.train --baseline $baselines --seeds $seeds --run-dir "$runs" --export best $resume ${TRAIN_OPTIONS:-} \
  --executor ray ${RAY_ADDRESS:+--address "$RAY_ADDRESS"} ||
  { echo "the sweep did not finish; continue it with RESUME=1 bash $0 $*" >&2; exit 1; }
echo "sweep: $(( ($(date +%s) - started) / 60 )) min"
# Install: each finished run as it is.
for baseline in $baselines; do
  for seed in $seeds; do
    if [ "$seed" = 0 ]; then install=--ship; else install=--keep; fi
    # shellcheck disable=SC2086
    python -m cabinbench.train --baseline "$baseline" --seed "$seed" --run-dir "$runs/${baseline}__seed$seed" \
      --export best --resume "$install" --no-progress ${TRAIN_OPTIONS:-} > /dev/null
  done
done
