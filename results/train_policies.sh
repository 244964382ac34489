#!/usr/bin/env bash
# Train every learned policy the committed results use, with the default training config: the four ablations at
# seed 0 (installed with --ship, the leaderboard's policies) and at seeds 1 and 2 (kept with --keep, the ablation
# table's). Training is deterministic on a CPU: the same code reproduces the committed policies and training records.
# Usage: bash results/train_policies.sh [SEED ...]   (from the repository root; default seeds 0 1 2; the four runs of
# one seed take about 40 minutes on 2 cores, so all twelve take about two hours), then
# bash results/make_results.sh learned to score them.
set -euo pipefail
seeds=${*:-0 1 2}
runs=runs/train_policies  # this script's own run directories, started afresh
rm -rf "$runs"
mkdir -p "$runs"
for baseline in ppo_gail ppo ppo_icm ppo_gail_only; do
  for seed in $seeds; do
    if [ "$seed" = 0 ]; then install=--ship; else install=--keep; fi
    echo "python -m cabinbench.train --baseline $baseline --seed $seed $install --no-progress" \
         "--run-dir $runs/${baseline}__seed$seed > $runs/${baseline}__seed$seed.log 2>&1"
  done
done | xargs -d '\n' -P "$(nproc)" -I{} bash -c {}
