#!/usr/bin/env bash
# Train ppo_gail_study, the study's configuration as ML-Agents runs it (baselines/ppo_gail/study.py), seeds 0, 1
# and 2 one after another, each as its two networks: the cleaning one (6 M steps on a320_cell, its checkpoint
# chosen on cabin-v1-val every 250 iterations) and the tracking one (2 M steps on a320_tracking_cell, its last
# checkpoint). Seed 0 is installed with --ship (baselines/ppo_gail/checkpoints/ppo_gail_study_<stage>.pt), seeds 1
# and 2 with --keep (results/training/ppo_gail_study_<stage>/seed<S>/). One run uses one core: the shipped pair
# took 2.9 h for its cleaning network and 1.9 h for its tracking one on this shared 2-core machine. The two
# networks train apart, so STAGES=cleaning and STAGES=tracking run them on two cores side by side. An interrupted
# run continues with the same command: a run directory with checkpoints is resumed, and a finished run is only
# exported again.
# Usage: [STAGES="cleaning tracking"] bash scripts/train_study_policies.sh [SEED ...]   (from the repository root;
# default seeds 0 1 2), then bash scripts/make_results.sh learned to score them.
set -euo pipefail
seeds=${*:-0 1 2}
for seed in $seeds; do
  if [ "$seed" = 0 ]; then install=--ship; else install=--keep; fi
  for stage in ${STAGES:-cleaning tracking}; do
    run_dir=runs/train/ppo_gail_study_${stage}__seed$seed
    resume=""
    if [ -d "$run_dir/checkpoints" ]; then resume=--resume; fi
    python -m cabinbench.train --baseline ppo_gail_study --stage "$stage" --seed "$seed" --workers 1 \
      --run-dir "$run_dir" $resume $install --no-progress
    echo "seed $seed, $stage: finished at $(date -u +%H:%M:%S)"
  done
done
