#!/usr/bin/env bash
# Train ppo_gail_suite: our ppo_gail trained on the suite cabin-v1-train through CabinBench/Suite-v0 (a new layout
# of the suite at every reset), seeds 0 to 4 one after another on one core. Budget: 400 iterations of 64 envs x 64
# steps (1.6 M steps), half the single-cell ppo_gail's 800 (13-31 minutes a seed, validation included, on one core
# of this shared 2-core machine, as its load allows); the expert demonstrates once on each of 8 suite layouts (the
# planner is deterministic: a repeat adds nothing); the checkpoints of iterations 200 and 400 play 10 layouts of
# cabin-v1-val and the better is exported (--export best).
# An interrupted seed continues with the same command, from its latest checkpoint; a finished one is taken as it
# is. The run folders live in results/training_runs/train_suite_policies/ and are committed as their runs finish
# (git ignores their checkpoints), as scripts/train_policies.sh's are. Once every seed has finished, seed 0 is
# installed with --ship (baselines/ppo_gail/checkpoints/ppo_gail_suite.pt, results/training/ppo_gail_suite/) and
# seeds 1 to 4 with --keep (results/training/ppo_gail_suite/seed<S>/): not before, so that the policies installed
# are always the ones their committed records were played with, until
# bash scripts/make_results.sh learned ppo_gail_suite plays them (its generalisation-gap runs too).
# Usage: bash scripts/train_suite_policies.sh [SEED ...]   (from the repository root; default seeds 0 1 2 3 4).
set -euo pipefail
seeds=${*:-0 1 2 3 4}
runs=results/training_runs/train_suite_policies  # this script's own run folders
train() {  # seed, then further options of train
  local seed=$1; shift
  python -m cabinbench.train --baseline ppo_gail --suite cabin-v1-train --seed "$seed" --iterations 400 \
    --demo-layouts 8 --demo-episodes 1 --validation-episodes 10 --export best --threads 1 --save-interval 50 \
    --run-dir "$runs/ppo_gail_suite__seed$seed" --resume --no-progress "$@"
}
for seed in $seeds; do
  train "$seed"
  echo "seed $seed finished at $(date -u +%H:%M:%S)"
done
for seed in $seeds; do
  [ -f "$runs/ppo_gail_suite__seed$seed/policy.pt" ] || { echo "not installed: seed $seed has not finished" >&2; exit 0; }
done
for seed in $seeds; do
  if [ "$seed" = 0 ]; then install=--ship; else install=--keep; fi
  train "$seed" "$install" > /dev/null
done
echo "installed: seeds $seeds; play their records with bash scripts/make_results.sh learned ppo_gail_suite"
