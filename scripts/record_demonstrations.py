"""Record the expert's demonstrations as datasets: varied episodes (random start poses, the planner's path
perturbed by noise on its executed actions) over several cells (``baselines/ppo_gail/datasets.py``).

    python scripts/record_demonstrations.py [--layout NAME ...] [--episodes N] [--seed S]
        [--action-noise STD] [--max-steps N] [--minari-id NAMESPACE/NAME-vN] [--team-npz FILE --agents K]

One robot: a Minari dataset (in ``MINARI_DATASETS_PATH``, by default ``~/.minari/datasets``), which
``minari.load_dataset(ID)`` loads. ``--team-npz``: the team format (``datasets.py`` documents its keys), which
``--demonstrations FILE`` of the train command takes as GAIL's demonstrations. Needs
``pip install "cabinbench[test]"`` (minari with h5py) for the Minari dataset.
"""

from __future__ import annotations

import sys

from cabinbench.baselines.ppo_gail.datasets import DEFAULT_ACTION_NOISE, record_team_npz, write_minari_dataset

from cabinbench.cli import ArgumentParser, output_file, positive_int, user_errors

DEFAULT_LAYOUTS = ("a320_cell", "a320_tracking_cell")


@user_errors
def main(argv: list[str] | None = None) -> int:
    parser = ArgumentParser(
        prog="python scripts/record_demonstrations.py", description=__doc__.split("\n")[0]
    )
    parser.add_argument("--layout", action="append", metavar="NAME", help="a cell to demonstrate (repeat)")
    parser.add_argument("--episodes", type=positive_int, default=20, help="episodes per layout (20)")
    parser.add_argument("--seed", type=int, default=0, help="reset seed of the first episode of each layout")
    parser.add_argument("--action-noise", type=float, default=DEFAULT_ACTION_NOISE, metavar="STD")
    parser.add_argument("--max-steps", type=positive_int, default=None, help="episode step limit")
    parser.add_argument("--minari-id", default="cabinbench/boustrophedon-v0", help="the Minari dataset's id")
    parser.add_argument("--team-npz", type=output_file(".npz"), help="record a team's dataset here instead")
    parser.add_argument("--agents", type=positive_int, default=2, help="robots of the team (2)")
    args = parser.parse_args(argv)
    if args.action_noise < 0:
        parser.error(f"argument --action-noise: {args.action_noise} is negative; give a std of 0 or more")
    layouts = args.layout or list(DEFAULT_LAYOUTS)
    options = {"action_noise": args.action_noise, "max_steps": args.max_steps}
    if args.team_npz:
        summary = record_team_npz(args.team_npz, layouts, args.episodes, args.agents, args.seed, **options)
        print(f"{args.team_npz}: {summary['steps']} rows, mean coverage {summary['coverage']:.3f}")
    else:
        dataset = write_minari_dataset(args.minari_id, layouts, args.episodes, args.seed, **options)
        print(f"{args.minari_id}: {dataset.total_episodes} episodes, {dataset.total_steps} steps")
    return 0


if __name__ == "__main__":
    sys.exit(main())
