#!/usr/bin/env bash
# Regenerate every committed result: the recorded runs, the leaderboard, its figures and the paper.
# Usage: bash scripts/make_results.sh [learned [BASELINE ...]]   (from the repository root)
# It scores the policies in the repository; scripts/train_policies.sh retrains them first, if wanted.
# With `learned`, only the learned baselines are played again (after retraining them): the records of the classic
# baselines are kept, since nothing they depend on changed; with baselines named after it, only theirs (a
# baseline's policies and records stay together: retrain, install and record one baseline at a time).
# Time on 2 cores with nothing else running: the classic baselines about half an hour; a learned baseline with 5
# seeds 35-45 minutes (265 episodes a policy), the team with 5 seeds (three team sizes) about an hour and a half.
# An interrupted regeneration continues with the same command and RESUME=1: the runs that had finished keep their
# records and are not played again; an unfinished run is played again from its start.
set -euo pipefail
all_learned="ppo_gail ppo ppo_icm ppo_gail_only ppo_gail_study ppo_gail_team ppo_gail_suite bc dagger ppo_lstm"
staging=runs/make_results  # each run plays into a folder of its own here; its records move on once it has finished
done_runs=$staging/done    # one line for each finished run: the arguments of its `play`
usage="usage: [RESUME=1] bash scripts/make_results.sh [learned [BASELINE ...]]; learned baselines: $all_learned"
classic=true learned_baselines=$all_learned
if [ $# -gt 0 ]; then
  [ "$1" = learned ] || { echo "$usage" >&2; exit 2; }
  shift
  classic=false learned_baselines=${*:-$all_learned}
  for baseline in $learned_baselines; do
    [[ " $all_learned " == *" $baseline "* ]] || { echo "no learned baseline $baseline; $usage" >&2; exit 2; }
  done
fi
if [ "${RESUME:-0}" = 1 ]; then
  [ -f "$done_runs" ] || { echo "nothing to resume: no $done_runs; run the command without RESUME=1" >&2; exit 2; }
else
  if $classic; then
    rm -rf results/runs results/ablation_runs
  else
    for baseline in $learned_baselines; do rm -f results/{runs,ablation_runs}/*__"$baseline"__*; done
  fi
  rm -rf results/figures "$staging"
  mkdir -p "$staging"
  : > "$done_runs"
fi
learns() { [[ " $learned_baselines " == *" $1 "* ]]; }  # whether this regeneration plays learned baseline $1
# A learned baseline's policies: "shipped" (baselines/ppo_gail/checkpoints/<baseline>.pt, the default) and each
# training seed's kept in results/training/<baseline>/seed<S>/ (`train --keep`); policy_config gives a policy's
# cabinbench.run --config (none for the shipped one). ppo_gail_study is a pair of networks, named by its cleaning
# one: ppo_gail_study_cleaning.pt beside ppo_gail_study_tracking.pt, each further seed's pair kept in
# results/training/ppo_gail_study_{cleaning,tracking}/seed<S>/ (scripts/train_study_policies.sh).
policies_of() { local policy name=$1
  [ "$name" = ppo_gail_study ] && name=ppo_gail_study_cleaning
  [ -f "baselines/ppo_gail/checkpoints/$name.pt" ] && echo shipped
  for policy in results/training/"$name"/seed*/policy.pt; do [ -f "$policy" ] && echo "$policy"; done; return 0; }
policy_config() {
  case $1 in
    shipped) ;;
    */ppo_gail_study_cleaning/*) printf '%s\n' --config "{\"cleaning\": \"$1\", \"tracking\": \"${1/_cleaning/_tracking}\"}" ;;
    *) printf '%s\n' --config "{\"checkpoint\": \"$1\"}" ;;
  esac
}
# Every run is queued as one `play` line, and the queue runs at the end, one run per core: each run writes files
# of its own, and the leaderboard orders episodes by seed, not by when they finished.
play() {  # one run: the folder its records go to, then cabinbench.run's arguments
  local out=$1 key folder
  key=$(printf '%q ' "$@")
  folder=$staging/$(md5sum <<< "$key" | cut -c1-16)
  shift
  grep -qxF "$key" "$done_runs" && return 0
  # the records move under names claimed in $out: two runs started in the same second share a name
  rm -rf "$folder" && python -m cabinbench.run --out "$folder" "$@" > /dev/null &&
    python -c 'import sys; from cabinbench.records import move_runs; move_runs(*sys.argv[1:])' "$folder" "$out" &&
    rmdir "$folder" && echo "$key" >> "$done_runs"
}
export -f play
export staging done_runs
queue=$(mktemp)
trap 'rm -f "$queue"' EXIT
runs() { local seeds=$1 episodes=$2 out=$3 seed; shift 3
  for seed in $seeds; do printf '%q ' play "$out" --episodes "$episodes" --seed "$seed" "$@"; echo; done >> "$queue"; }
# 20 episodes per setting: 5 runs (seeds 0, 100, ..., 400) of 4 episodes (episode i uses seed + i)
run() { runs "0 100 200 300 400" 4 "${OUT:-results/runs}" "$@"; }

if $classic; then
  # Classic baselines on the four cabin layouts, both protocols.
  for layout in a320_cell shape_changed b777_3col full_cabin; do
    for protocol in sequential open; do
      for baseline in random_bounce boustrophedon; do
        run --baseline "$baseline" --layout "$layout" --protocol "$protocol"
      done
    done
  done

  # The study's random motion as it describes it (§2.2.1, §5.2.3): any new heading, its 3000-step limit.
  run --baseline random_bounce_study --layout a320_cell --protocol sequential --max-steps 3000

  # Classic baselines on the building maps (one cell each, so the protocols coincide): plain coverage.
  for layout in office_floor mall_corridor meeting_area; do
    for baseline in random_bounce boustrophedon; do
      run --baseline "$baseline" --layout "$layout" --protocol open
    done
  done

  # Teams: K = 1, 2, 4 on the two large layouts (K = 1 is recorded above); the planner in both protocols.
  team_run() { runs "0 100" 5 results/runs "$@"; }
  for layout in full_cabin b777_3col; do
    for agents in 2 4; do
      team_run --agents "$agents" --baseline random_bounce --layout "$layout" --protocol sequential
      for protocol in sequential open; do
        team_run --agents "$agents" --baseline boustrophedon --layout "$layout" --protocol "$protocol"
      done
    done
  done
fi

# Learned policies on the named cabin layouts, zero-shot on all but the training cell: the shipped policy's records
# in results/runs, every other training seed's in results/ablation_runs (results/ablation.md; the reproduction
# report reads ppo_gail_study's every seed).
for baseline in $learned_baselines; do
  [ "$baseline" = ppo_gail_suite ] && continue  # scored on the suites only (below)
  for policy in $(policies_of "$baseline"); do
    mapfile -t config < <(policy_config "$policy")
    out=results/runs; [ "$policy" = shipped ] || out=results/ablation_runs
    for layout in a320_cell shape_changed b777_3col full_cabin; do
      OUT=$out run --baseline "$baseline" --layout "$layout" --protocol sequential "${config[@]}"
    done
  done
done

# Teams of K = 2, 4 on the two large layouts (K = 1 is recorded above): the learned team (ppo_gail_team, one policy
# shared by the robots) beside the single-robot ppo_gail on every robot; every training seed of both.
for baseline in ppo_gail_team ppo_gail; do
  learns "$baseline" && [ -f baselines/ppo_gail/checkpoints/ppo_gail_team.pt ] || continue
  for policy in $(policies_of "$baseline"); do
    mapfile -t config < <(policy_config "$policy")
    out=results/runs; [ "$policy" = shipped ] || out=results/ablation_runs
    for layout in full_cabin b777_3col; do
      for agents in 2 4; do
        runs "0 100" 5 "$out" --agents "$agents" --baseline "$baseline" --layout "$layout" --protocol sequential \
          "${config[@]}"
      done
    done
  done
done

# The suites (benchmark protocol v1): one episode on every layout of cabin-v1-test, then of cabin-v1-ood, each
# from start poses drawn from the episode's seed (a team's robots too: each drives from where it stands to the
# start of its share), by every policy of every learned baseline (the team with K = 1, 2 and 4); then the
# classic suite from seeded random starts, 5 episodes a layout, so that the named layouts' intervals measure
# more than action noise. The classic baselines first.
suite_run() { { printf '%q ' play results/runs --seed 0 "$@"; echo; } >> "$queue"; }
for suite in cabin-v1-test cabin-v1-ood classic; do
  options=(); [ "$suite" = classic ] && options=(--start random --episodes-per-layout 5)
  if $classic; then
    for baseline in boustrophedon random_bounce; do suite_run --suite "$suite" "${options[@]}" --baseline "$baseline"; done
    if [ "$suite" != classic ]; then
      for agents in 2 4; do suite_run --suite "$suite" --baseline boustrophedon --agents "$agents"; done
    fi
  fi
  for baseline in $learned_baselines; do
    teams=(""); [ "$baseline" = ppo_gail_team ] && teams=("--agents 1" "--agents 2" "--agents 4")
    for policy in $(policies_of "$baseline"); do
      mapfile -t config < <(policy_config "$policy")
      for team in "${teams[@]}"; do
        # shellcheck disable=SC2086  # $team is empty or "--agents K"
        suite_run --suite "$suite" "${options[@]}" --baseline "$baseline" $team "${config[@]}"
      done
    done
  done
done

# The generalisation gap's train column (the leaderboard's "Generalisation gap", cabinbench/leaderboard/gap.py):
# ppo_gail's is its two training cells from random starts (its classic-suite episodes above) and, for the record, 50
# layouts of cabin-v1-train it never saw; ppo_gail_suite's is, for each training seed, the first 30 layouts of
# cabin-v1-train on which its run began an episode for certain, reconstructed from the run's config.json
# (suite_draws prints how many of the suite's first layouts hold them). Test and ood are the whole suites, above.
if learns ppo_gail; then
  for policy in $(policies_of ppo_gail); do
    mapfile -t config < <(policy_config "$policy")
    suite_run --suite cabin-v1-train --layouts 50 --baseline ppo_gail "${config[@]}"
  done
fi
if learns ppo_gail_suite; then
  for policy in $(policies_of ppo_gail_suite); do
    run_config=results/training/ppo_gail_suite/config.json
    [ "$policy" = shipped ] || run_config=$(dirname "$policy")/config.json
    trained=$(python -m cabinbench.baselines.ppo_gail.training.suite_draws --layouts 30 "$run_config")
    mapfile -t config < <(policy_config "$policy")
    suite_run --suite cabin-v1-train --layouts "$trained" --baseline ppo_gail_suite "${config[@]}"
  done
fi

xargs -d '\n' -P "$(nproc)" -I{} bash -c {} < "$queue" ||
  { echo "some runs did not finish (the others' records are kept); continue with RESUME=1 bash $0 $*" >&2; exit 1; }
if $classic; then
  bash scripts/random_motion.sh  # the random-motion gap of §5.2.3, factor by factor (results/random_motion.md)
fi
python -m cabinbench.leaderboard
python -m cabinbench.leaderboard --site results/site
python -m cabinbench.paper
