#!/usr/bin/env bash
# Train ppo_gail_study, the study's configuration as ML-Agents runs it (baselines/ppo_gail/study.py), seeds 0, 1
# and 2 one after another, each as its two networks: the cleaning one (6 M steps on a320_cell, its checkpoint
# chosen on cabin-v1-val every 250 iterations) and the tracking one (2 M steps on a320_tracking_cell, its last
# checkpoint). One run uses one core: the shipped pair took 2.9 h for its cleaning network and 1.9 h for its
# tracking one on this shared 2-core machine. The two networks train apart, so STAGES=cleaning and
# STAGES=tracking run them on two cores side by side. An interrupted run continues with the same command, from
# its latest checkpoint; a finished one is taken as it is. The run folders live in
# results/training_runs/train_study_policies/ and are committed as their runs finish (git ignores their
# checkpoints), as scripts/train_policies.sh's are.
# Once every run of both networks has finished, seed 0 is installed with --ship
# (baselines/ppo_gail/checkpoints/ppo_gail_study_<stage>.pt, its records in results/training/ppo_gail_study_<stage>/)
# and seeds 1 and 2 with --keep (results/training/ppo_gail_study_<stage>/seed<S>/): not before, so that the pair
# installed is always the pair its committed records were played with, until bash scripts/make_results.sh learned
# ppo_gail_study plays them.
# Usage: [STAGES="cleaning tracking"] bash scripts/train_study_policies.sh [SEED ...]   (from the repository root;
# default seeds 0 1 2).
set -euo pipefail
seeds=${*:-0 1 2}
runs=results/training_runs/train_study_policies  # this script's own run folders
train() {  # seed, stage, then further options of train
  local seed=$1 stage=$2; shift 2
  python -m cabinbench.train --baseline ppo_gail_study --stage "$stage" --seed "$seed" --workers 1 \
    --run-dir "$runs/ppo_gail_study_${stage}__seed$seed" --resume --no-progress "$@"
}
for seed in $seeds; do
  for stage in ${STAGES:-cleaning tracking}; do
    train "$seed" "$stage"
    echo "seed $seed, $stage: finished at $(date -u +%H:%M:%S)"
  done
done
for seed in $seeds; do
  for stage in cleaning tracking; do
    [ -f "$runs/ppo_gail_study_${stage}__seed$seed/policy.pt" ] ||
      { echo "not installed: seed $seed's $stage network has not finished" >&2; exit 0; }
  done
done
for seed in $seeds; do
  if [ "$seed" = 0 ]; then install=--ship; else install=--keep; fi
  for stage in cleaning tracking; do train "$seed" "$stage" "$install" > /dev/null; done
done
echo "installed: seeds $seeds; play their records with bash scripts/make_results.sh learned ppo_gail_study"
