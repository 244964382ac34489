#!/usr/bin/env bash
# Regenerate every committed result: the recorded runs, the leaderboard, its figures and the paper.
# Usage: bash scripts/make_results.sh [learned]   (from the repository root; about half an hour on 2 cores)
# It scores the policies in the repository; scripts/train_policies.sh retrains them first, if wanted.
# With `learned`, only the learned baselines are played again (after retraining them): the records of the classic
# baselines are kept, since nothing they depend on changed.
# An interrupted regeneration continues with RESUME=1 bash scripts/make_results.sh [learned]: the runs that had
# finished keep their records and are not played again; an unfinished run is played again from its start.
set -euo pipefail
learned_baselines="ppo_gail ppo ppo_icm ppo_gail_only ppo_gail_study ppo_gail_team ppo_gail_suite bc dagger ppo_lstm"
staging=runs/make_results  # each run plays into a folder of its own here; its records move on once it has finished
done_runs=$staging/done    # one line for each finished run: the arguments of its `play`
if [ $# -gt 1 ] || { [ $# = 1 ] && [ "$1" != learned ]; }; then
  echo "usage: [RESUME=1] bash scripts/make_results.sh [learned]" >&2
  exit 2
elif [ "${RESUME:-0}" = 1 ]; then
  [ -f "$done_runs" ] || { echo "nothing to resume: no $done_runs; run bash $0 $* to start" >&2; exit 2; }
  classic=$([ $# = 0 ] && echo true || echo false)
else
  if [ $# = 1 ]; then
    classic=false
    for baseline in $learned_baselines; do rm -f results/runs/*__"$baseline"__*; done
  else
    classic=true
    rm -rf results/runs
  fi
  rm -rf results/ablation_runs results/figures "$staging"
  mkdir -p "$staging"
  : > "$done_runs"
fi
# Every run is queued as one `play` line, and the queue runs at the end, one run per core: each run writes files
# of its own, and the leaderboard orders episodes by seed, not by when they finished.
play() {  # one run: the folder its records go to, then cabinbench.run's arguments
  local out=$1 key folder
  key=$(printf '%q ' "$@")
  folder=$staging/$(md5sum <<< "$key" | cut -c1-16)
  shift
  grep -qxF "$key" "$done_runs" && return 0
  rm -rf "$folder" && python -m cabinbench.run --out "$folder" "$@" > /dev/null &&
    mkdir -p "$out" && mv "$folder"/* "$out"/ && rmdir "$folder" && echo "$key" >> "$done_runs"
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

# Learned policies (shipped checkpoints), zero-shot on all but the training cell. ppo_gail_study is a pair of
# networks, ppo_gail_study_cleaning.pt and ppo_gail_study_tracking.pt.
for baseline in $learned_baselines; do
  [ "$baseline" = ppo_gail_suite ] && continue  # scored on the suites only (below): no classic rows recorded yet
  if [ -f "baselines/ppo_gail/checkpoints/$baseline.pt" ] || [ -f "baselines/ppo_gail/checkpoints/${baseline}_cleaning.pt" ]; then
    for layout in a320_cell shape_changed b777_3col full_cabin; do
      run --baseline "$baseline" --layout "$layout" --protocol sequential
    done
  fi
done

# The learned team (ppo_gail_team, one policy shared by the robots) for K = 2, 4 on the two large layouts (K = 1 is
# recorded above), beside the single-robot ppo_gail run on every robot of the team; every training seed of both.
if [ -f baselines/ppo_gail/checkpoints/ppo_gail_team.pt ]; then
  for layout in full_cabin b777_3col; do
    for agents in 2 4; do
      for baseline in ppo_gail_team ppo_gail; do
        runs "0 100" 5 results/runs --agents "$agents" --baseline "$baseline" --layout "$layout" --protocol sequential
      done
      for policy in results/training/{ppo_gail,ppo_gail_team}/seed*/policy.pt; do
        [ -f "$policy" ] || continue
        baseline=$(basename "$(dirname "$(dirname "$policy")")")
        runs "0 100" 5 results/ablation_runs --agents "$agents" --baseline "$baseline" --layout "$layout" \
          --protocol sequential --config "{\"checkpoint\": \"$policy\"}"
      done
    done
  done
fi

# The suites (benchmark protocol v1): one episode on every layout of cabin-v1-test, then of cabin-v1-ood, each
# from start poses drawn from the episode's seed (a team's robots too: each drives from where it stands to the
# start of its share); the classic baselines first, then the shipped policies.
suite_run() { { printf '%q ' play results/runs --seed 0 "$@"; echo; } >> "$queue"; }
for suite in cabin-v1-test cabin-v1-ood; do
  if $classic; then
    suite_run --suite "$suite" --baseline boustrophedon
    suite_run --suite "$suite" --baseline random_bounce
    suite_run --suite "$suite" --baseline boustrophedon --agents 2
    suite_run --suite "$suite" --baseline boustrophedon --agents 4
  fi
  for baseline in ppo_gail ppo ppo_icm ppo_gail_only bc dagger ppo_lstm; do
    if [ -f "baselines/ppo_gail/checkpoints/$baseline.pt" ]; then
      suite_run --suite "$suite" --baseline "$baseline"
    fi
  done
  # The learners from the planner (bc, dagger) and with memory (ppo_lstm): every kept seed on every layout.
  for policy in results/training/{bc,dagger,ppo_lstm}/seed*/policy.pt; do
    [ -f "$policy" ] || continue
    baseline=$(basename "$(dirname "$(dirname "$policy")")")
    suite_run --suite "$suite" --baseline "$baseline" --config "{\"checkpoint\": \"$policy\"}"
  done
  if [ -f baselines/ppo_gail/checkpoints/ppo_gail_study_cleaning.pt ]; then
    suite_run --suite "$suite" --baseline ppo_gail_study
  fi
done

# The named layouts from seeded random starts too (the classic suite, 5 episodes a layout), so that their intervals
# measure more than action noise: the planner, random motion, our tuned learner and the study's configuration.
for baseline in boustrophedon random_bounce ppo_gail ppo_gail_study; do
  if $classic || [ "$baseline" = ppo_gail ] || [ "$baseline" = ppo_gail_study ]; then
    suite_run --suite classic --start random --episodes-per-layout 5 --baseline "$baseline"
  fi
done

# The learned team on the first 50 layouts of cabin-v1-test, K = 1, 2 and 4, every training seed.
for policy in baselines/ppo_gail/checkpoints/ppo_gail_team.pt results/training/ppo_gail_team/seed*/policy.pt; do
  [ -f "$policy" ] || continue
  config=()
  if [ "$policy" != baselines/ppo_gail/checkpoints/ppo_gail_team.pt ]; then  # the shipped one runs without
    config=(--config "{\"checkpoint\": \"$policy\"}")
  fi
  for agents in 1 2 4; do
    suite_run --suite cabin-v1-test --layouts 50 --baseline ppo_gail_team --agents "$agents" "${config[@]}"
  done
done

# The generalisation gap (the leaderboard's "Generalisation gap", cabinbench/leaderboard/gap.py): the learned
# policies trained on the two cells (ppo_gail) and on cabin-v1-train (ppo_gail_suite, scripts/train_suite_policies.sh),
# every training seed, on layouts they trained on, on 50 layouts of cabin-v1-test and on 25 of cabin-v1-ood; the
# shipped ppo_gail's test, ood and classic-suite episodes are the ones above. ppo_gail's train column is its two cells
# from random starts (its classic-suite episodes there, the whole suite played so that the classic suite's table has
# every seed on every layout; its cabin-v1-train layouts are ones it never saw);
# ppo_gail_suite's is the first 30 layouts of cabin-v1-train on which every seed's run began an episode for certain,
# reconstructed from the runs' config.json: suite_draws prints how many of the suite's first layouts hold them.
# Sized to one session's shared core.
gap_run() { local suite=$1 layouts=$2 baseline=$3 policy=${4:-}; local config=()
  if [ -n "$policy" ]; then config=(--config "{\"checkpoint\": \"$policy\"}"); fi
  suite_run --suite "$suite" --layouts "$layouts" --baseline "$baseline" "${config[@]}"; }
if [ -f baselines/ppo_gail/checkpoints/ppo_gail.pt ]; then
  gap_run cabin-v1-train 50 ppo_gail
fi
for policy in results/training/ppo_gail/seed*/policy.pt; do
  [ -f "$policy" ] || continue
  gap_run cabin-v1-train 50 ppo_gail "$policy"
  gap_run cabin-v1-test 50 ppo_gail "$policy"
  gap_run cabin-v1-ood 25 ppo_gail "$policy"
  suite_run --suite classic --start random --episodes-per-layout 5 --baseline ppo_gail --config "{\"checkpoint\": \"$policy\"}"
done
suite_configs=()
for config in results/training/ppo_gail_suite/config.json results/training/ppo_gail_suite/seed*/config.json; do
  if [ -f "$config" ]; then suite_configs+=("$config"); fi
done
if [ ${#suite_configs[@]} -gt 0 ]; then
  suite_trained=$(python -m cabinbench.baselines.ppo_gail.training.suite_draws --layouts 30 "${suite_configs[@]}")
fi
for policy in baselines/ppo_gail/checkpoints/ppo_gail_suite.pt results/training/ppo_gail_suite/seed*/policy.pt; do
  [ -f "$policy" ] || continue
  if [ "$policy" = baselines/ppo_gail/checkpoints/ppo_gail_suite.pt ]; then policy=""; fi  # the shipped one
  gap_run cabin-v1-test 50 ppo_gail_suite "$policy"
  gap_run cabin-v1-ood 25 ppo_gail_suite "$policy"
  gap_run cabin-v1-train "$suite_trained" ppo_gail_suite "$policy"
done

# The learned baselines' further training runs (results/ablation.md): the policies of seeds 1, 2, ... kept in
# results/training/<baseline>/seed<S>/ by `python -m cabinbench.train --baseline <baseline> --seed <S> --keep`.
for policy in results/training/*/seed*/policy.pt; do
  [ -f "$policy" ] || continue
  baseline=$(basename "$(dirname "$(dirname "$policy")")")
  [ "$baseline" = ppo_gail_suite ] && continue  # scored on the suites (above)
  case $baseline in ppo_gail_study_*) continue ;; esac  # a pair of stages: below
  for layout in a320_cell shape_changed b777_3col full_cabin; do
    OUT=results/ablation_runs run --baseline "$baseline" --layout "$layout" --protocol sequential --config "{\"checkpoint\": \"$policy\"}"
  done
done
# The study's configuration, further seeds: the pair `train --baseline ppo_gail_study --stage cleaning|tracking --seed S
# --keep` kept in results/training/ppo_gail_study_{cleaning,tracking}/seed<S>/ (the reproduction report reads them).
for cleaning in results/training/ppo_gail_study_cleaning/seed*/policy.pt; do
  tracking=${cleaning/_cleaning/_tracking}
  [ -f "$cleaning" ] && [ -f "$tracking" ] || continue
  for layout in a320_cell shape_changed b777_3col full_cabin; do
    OUT=results/ablation_runs run --baseline ppo_gail_study --layout "$layout" --protocol sequential \
      --config "{\"cleaning\": \"$cleaning\", \"tracking\": \"$tracking\"}"
  done
done

xargs -d '\n' -P "$(nproc)" -I{} bash -c {} < "$queue" ||
  { echo "some runs did not finish (the others' records are kept); continue with RESUME=1 bash $0 $*" >&2; exit 1; }
if $classic; then
  bash scripts/random_motion.sh  # the random-motion gap of §5.2.3, factor by factor (results/random_motion.md)
fi
python -m cabinbench.leaderboard
python -m cabinbench.leaderboard --site results/site
python -m cabinbench.paper
