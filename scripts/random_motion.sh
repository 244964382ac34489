#!/usr/bin/env bash
# The random-motion gap of §5.2.3 tested (results/random_motion.md): random_bounce_study on a320_cell with every
# combination of the study's speed, turn rate, cell width and 60 s budget (cabinbench/paper/random_motion.py says
# where each value comes from), 20 episodes a setting: seeds 0, 100, ..., 400, 4 episodes each, as
# scripts/make_results.sh records its runs. About 5 minutes on one core.
# Usage: bash scripts/random_motion.sh   (from the repository root)
set -euo pipefail
out=results/random_motion
rm -f "$out"/*.jsonl "$out"/*.npz
rm -rf "$out/layouts"
python -c 'from cabinbench.paper.random_motion import write_layouts; write_layouts()'
for layout in a320_cell "$out"/layouts/*.yaml; do
  for steps in 3000 600; do  # ours (3000 steps of 0.1 s), the study's 60 s
    for seed in 0 100 200 300 400; do
      python -m cabinbench.run --baseline random_bounce_study --layout "$layout" --protocol sequential \
        --max-steps "$steps" --episodes 4 --seed "$seed" --out "$out" > /dev/null
    done
  done
done
python -m cabinbench.paper --random-motion
