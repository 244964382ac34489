#!/usr/bin/env bash
# Train ppo_gail_team, the learned team (one policy shared by every robot), in two stages per seed; seeds 0 to 4
# one after another (8-15 + 3-7 minutes of training a seed on one core of this shared 2-core machine):
# 1. K = 2 on full_cabin: 450 iterations from the shipped ppo_gail's actor with TeamTrainConfig's defaults, the
#    checkpoint best on validation exported. A stage-1 run grown from another ppo_gail than the one shipped now
#    (its folder's init_policy.sha256) trains again.
# 2. K = 4: 100 iterations from stage 1's policy without the entropy bonus (with it the action std grows and the
#    team slows down: docs/experiments.md, "The learned team"), a checkpoint every 25 validated with four
#    robots, the best exported.
# An interrupted stage continues with the same command, from its latest checkpoint; a finished one is taken as
# it is. The run folders live in results/training_runs/train_team_policies/ and are committed as their runs
# finish (git ignores their checkpoints), as scripts/train_policies.sh's are. Once every seed's stage 2 has
# finished, seed 0 is installed with --ship (baselines/ppo_gail/checkpoints/ppo_gail_team.pt,
# results/training/ppo_gail_team/) and seeds 1 to 4 with --keep (results/training/ppo_gail_team/seed<S>/): not
# before, so that the team installed is always the one its committed records were played with, until
# bash scripts/make_results.sh learned ppo_gail_team plays them.
# Usage: bash scripts/train_team_policies.sh [SEED ...]   (from the repository root; default seeds 0 1 2 3 4).
set -euo pipefail
seeds=${*:-0 1 2 3 4}
runs=results/training_runs/train_team_policies  # this script's own run folders
sha() { sha256sum "$1" | cut -c1-64; }
# A run dir holds the sha256 of the policy its run starts from (init_policy.sha256); one begun from another
# policy starts again, so that no run resumes on top of an actor it did not start from.
run_dir_from() { if [ "$(cat "$1/init_policy.sha256" 2>/dev/null)" != "$2" ]; then
  rm -rf "$1" && mkdir -p "$1" && echo "$2" > "$1/init_policy.sha256"; fi; }
stage2() {  # seed, then further options of train
  local seed=$1; shift
  python -m cabinbench.train --baseline ppo_gail_team --layout full_cabin --agents 4 --seed "$seed" \
    --iterations 100 --save-interval 25 --validation-interval 25 --export best \
    --init-policy "$runs/ppo_gail_team_k2__seed$seed/policy.pt" \
    --algorithm '{"entropy_coef": 0.0, "gail_strength": 0.02}' --run-dir "$runs/ppo_gail_team__seed$seed" \
    --resume --no-progress "$@"
}
init=$(sha baselines/ppo_gail/checkpoints/ppo_gail.pt)  # the actor stage 1 starts from
for seed in $seeds; do
  stage1=$runs/ppo_gail_team_k2__seed$seed
  run_dir_from "$stage1" "$init"
  python -m cabinbench.train --baseline ppo_gail_team --layout full_cabin --agents 2 --seed "$seed" \
    --iterations 450 --export best --run-dir "$stage1" --resume --no-progress
  run_dir_from "$runs/ppo_gail_team__seed$seed" "$(sha "$stage1/policy.pt")"
  stage2 "$seed"
  echo "seed $seed finished at $(date -u +%H:%M:%S)"
done
for seed in $seeds; do
  [ -f "$runs/ppo_gail_team__seed$seed/policy.pt" ] || { echo "not installed: seed $seed has not finished" >&2; exit 0; }
done
for seed in $seeds; do
  if [ "$seed" = 0 ]; then install=--ship; else install=--keep; fi
  stage2 "$seed" "$install" > /dev/null
done
echo "installed: seeds $seeds; play their records with bash scripts/make_results.sh learned ppo_gail_team"
