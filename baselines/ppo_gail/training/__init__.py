"""Training the learned baselines: PPO + curiosity (ICM) + GAIL and its ablations, with rsl-rl.

One policy, two behaviours. The study trained a cleaning cell (reach every goal marker of a cell) and a
tracking cell (the cell is clean, the bound to the next cell is open and a green exit landmark shows: drive
to it, then clean the next cell). Here a single policy is trained on both layouts at once
(``TrainConfig.layouts``: half the parallel envs run ``a320_cell``, half ``a320_tracking_cell``). The policy
tells the two situations apart from what its lidar sees: while goal markers show it cleans, once an
``exit`` tag shows it tracks. Chained cell after cell, that is the study's whole-cabin process (Fig. 4.15),
which ``full_cabin`` evaluates zero-shot.

Its parts, in the order a run goes through them:

1. ``config.TrainConfig``: every setting of a run, with its default and why (``study.study_config`` gives the
   study's own configuration instead: two networks trained apart, ``ppo_gail_study``; ``team_training``'s
   ``TeamTrainConfig`` a policy shared by a team, ``ppo_gail_team``, through the same functions: the
   config's ``make_env``, ``obs_groups``, ``initialise``, ``policy_name`` and ``episode_options`` are what
   differs).
2. ``loop.train(config, run_dir)``: records expert demonstrations with the boustrophedon planner (or reuses
   given ``.npz`` files), builds ``RslRlVecEnv(BatchedCoverageEnv(...))`` and rsl-rl's ``OnPolicyRunner``
   with the ``PPOCuriosityGail`` algorithm, then runs ``runner.learn(1)`` once per iteration under a tqdm
   bar; after each iteration it appends a row to ``metrics.csv``, every ``save_interval`` iterations it
   writes a checkpoint (atomically, ``checkpoints``), and at the end it draws ``curves.png``; ``metrics``
   turns what the runner logs into the rows of ``metrics.csv``.
3. ``validation.validate_checkpoints``: the policy of every ``validation_interval``-th checkpoint and of the
   last plays one episode on each of ``validation_episodes`` layouts of cabin-v1-val (``validation_suite``),
   from random starts with seeds the leaderboard does not use (``validation.csv``, with the headline
   ``clean_score``); then the last checkpoint (or, with ``export="best"``, the best there) is exported as
   the small shipped policy ``policy.pt``. Runs before cabin-v1-val validated on their training layouts.
4. Interrupted runs (Ctrl-C, a crash) keep every finished checkpoint and validation row;
   ``train(..., resume=True)`` continues from the latest checkpoint exactly as the run would have gone on:
   same weights, optimisers, normalisers, ICM and discriminator, the environments back in their episodes
   (replayed from how each began and the actions since), torch's random state and the logger's running
   episode sums; the iteration count goes on.

The run directory holds ``config.json``, ``demos/<layout>.npz``, ``checkpoints/model_<iteration>.pt`` (full
rsl-rl checkpoints: actor, critic, optimisers, ICM, discriminator), ``metrics.csv``, ``curves.png``,
``validation/policy_<iteration>.pt`` (each checkpoint's actor), ``validation.csv`` (their validation
episodes), ``policy.pt`` (the exported actor, see ``baselines.ppo_gail.policy``) and ``rsl_rl.log`` (what
rsl-rl prints while building the models).

The shipped policies (``baselines/ppo_gail/checkpoints``) come from ``python -m cabinbench.train --baseline
NAME --ship`` with the defaults below: 3.3 M steps, seed 0, 12-27 minutes a run on a 2-core CPU. ``--ship``
also keeps the run's ``config.json``, ``metrics.csv`` and ``validation.csv`` in ``results/training/``, from
which the leaderboard draws the training curves. Training is deterministic on a CPU (seeded, one torch
thread, envs seeded per index): ``scripts/train_policies.sh`` retrains all twelve policies of the results
(four ablations, seeds 0-2). Training times and the trials behind every default: ``docs/experiments.md``.
"""

from cabinbench.baselines.ppo_gail.training.config import (
    VALIDATION_DIR,
    VALIDATION_SEED,
    TrainConfig,
    default_run_dir,
    suite_sample,
)
from cabinbench.baselines.ppo_gail.training.loop import TrainResult, export_latest, train
from cabinbench.baselines.ppo_gail.training.validation import read_validation

__all__ = [
    "VALIDATION_DIR",
    "VALIDATION_SEED",
    "TrainConfig",
    "TrainResult",
    "default_run_dir",
    "export_latest",
    "read_validation",
    "suite_sample",
    "train",
]
