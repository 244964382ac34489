"""Learning curves (``cabinbench.leaderboard.curves``) from the records of real tiny training runs: the
CSV carries each run's seed, validated iterations and env steps, the figure is drawn, and the
leaderboard's section and the paper's name the seeds and the validation layouts."""

from __future__ import annotations

import json
import shutil
from pathlib import Path

import pandas as pd
import pytest

from cabinbench.commands import leaderboard
from cabinbench.commands.train import main as train_main
from cabinbench.leaderboard.curves import (
    CURVES_CSV,
    CURVES_FIGURE,
    learning_curves,
    learning_curves_section,
    read_learning_curves,
    write_learning_curves,
)
from cabinbench.training_records import read_metrics
from tests.test_run_and_leaderboard import run_main

ROOT = Path(__file__).resolve().parents[1]
NUM_ENVS, STEPS_PER_ENV = 4, 8
PPO = ["--baseline", "ppo", "--layout", "a320_cell", "--iterations", "2", "--num-envs", str(NUM_ENVS)]
PPO += ["--steps-per-env", str(STEPS_PER_ENV), "--max-steps", "20", "--save-interval", "1"]
PPO += ["--validation-episodes", "2", "--no-progress"]
BC = ["--baseline", "bc", "--layout", "a320_cell", "--iterations", "2", "--episodes-per-iteration", "2"]
BC += ["--max-steps", "60", "--epochs", "2", "--validation-episodes", "2", "--workers", "1", "--no-progress"]


@pytest.fixture(scope="module")
def trained(tmp_path_factory) -> Path:
    """``results/training`` of a folder where ppo trained seed 0 (``--ship``) and seed 1 (``--keep``), and
    bc seed 0 (``--ship``), each for 2 iterations on tiny settings."""
    folder = tmp_path_factory.mktemp("trained")
    with pytest.MonkeyPatch.context() as patch:
        patch.chdir(folder)
        (folder / "checkpoints").mkdir()
        assert train_main([*PPO, "--run-dir", "ppo0", "--ship", "--ship-dir", "checkpoints"]) == 0
        assert train_main([*PPO, "--run-dir", "ppo1", "--seed", "1", "--keep"]) == 0
        assert train_main([*BC, "--run-dir", "bc0", "--ship", "--ship-dir", "checkpoints"]) == 0
    return folder / "results" / "training"


def validated_on(run: Path) -> tuple[str, str]:
    """(validation layouts, metric) as a run's records say: on cabin-v1-val, scored with clean_score, where
    its config names it a ``validation_suite``; else on its training layout, scored by coverage."""
    config = json.loads((run / "config.json").read_text())
    validation = pd.read_csv(run / "validation.csv")
    if config.get("validation_suite") or config.get("method"):  # bc and dagger validate on cabin-v1-val
        layouts = f"cabin-v1-val ({validation['layout'].nunique()} layouts)"
        return layouts, "clean_score" if "clean_score" in validation else "coverage"
    return "training layouts a320_cell", "coverage"


def test_each_run_gives_its_seed_validated_iterations_and_env_steps(trained):
    curves = learning_curves(trained)
    for baseline, seed, run in (("ppo", 0, trained / "ppo"), ("ppo", 1, trained / "ppo" / "seed1")):
        rows = curves[(curves["baseline"] == baseline) & (curves["seed"] == seed)]
        validation = pd.read_csv(run / "validation.csv")
        assert list(rows["iteration"]) == sorted(set(validation["iteration"])) and 2 in set(rows["iteration"])
        # rsl-rl: an iteration is num_envs x steps per env
        assert list(rows["env_steps"]) == [
            iteration * NUM_ENVS * STEPS_PER_ENV for iteration in rows["iteration"]
        ]
        layouts, metric = validated_on(run)
        assert set(rows["validation_layouts"]) == {layouts} and set(rows["metric"]) == {metric}
        assert set(rows["env_steps_note"]) == {""}
        assert list(rows["validation_episodes"]) == list(validation.groupby("iteration")["episodes"].sum())
        assert list(rows["value"]) == pytest.approx(list(validation.groupby("iteration")[metric].mean()))

    bc = curves[curves["baseline"] == "bc"]
    assert list(zip(bc["seed"], bc["iteration"])) == [(0, 1), (0, 2)]
    steps = [int(row["steps"]) for row in read_metrics(trained / "bc" / "metrics.csv")]
    assert list(bc["env_steps"]) == [steps[0], steps[0] + steps[1]]  # every round collected so far
    assert 0 < steps[0] <= 2 * 60
    assert set(bc["validation_layouts"]) == {"cabin-v1-val (2 layouts)"}
    assert set(bc["metric"]) == {validated_on(trained / "bc")[1]}


def test_csv_figure_and_leaderboard_section_name_the_seeds_and_validation_layouts(trained, tmp_path):
    runs = tmp_path / "runs"
    status, _, _ = run_main(["--baseline", "random_bounce", "--layout", "a320_cell", "--max-steps", "30",
                             "--episodes", "1", "--out", str(runs)])  # fmt: skip
    assert status == 0
    out = tmp_path / "out"
    assert leaderboard.main(["--runs", str(runs), "--training", str(trained), "--out", str(out)]) == 0
    written = read_learning_curves(out / CURVES_CSV)
    assert set(zip(written["baseline"], written["seed"])) == {("bc", 0), ("ppo", 0), ("ppo", 1)}
    board = (out / "leaderboard.md").read_text(encoding="utf-8")
    assert "## Learning curves" in board and f"![learning curves](figures/{CURVES_FIGURE})" in board
    ppo_layouts, ppo_metric = validated_on(trained / "ppo")
    checkpoints = written[written["seed"] == 1]["iteration"].nunique()
    assert f"| `ppo` | 0, 1 (2) | {ppo_layouts} | {ppo_metric} | {checkpoints} | 0.00 M |" in board
    bc_metric = validated_on(trained / "bc")[1]
    assert f"| `bc` | 0 (1) | cabin-v1-val (2 layouts) | {bc_metric} | 2 |" in board
    # runs validated on their training layouts are named as such; bc, on cabin-v1-val, is not
    own_layouts_line = next(
        (line for line in board.splitlines() if line.startswith("Validated on their own")), ""
    )
    assert ("`ppo`" in own_layouts_line) == (ppo_layouts == "training layouts a320_cell")
    assert "`bc`" not in own_layouts_line
    # bc's records hold no rsl-rl losses: it has learning curves, and no per-run training figure
    assert (out / "figures" / "training__ppo.png").is_file() and not (
        out / "figures" / "training__bc.png"
    ).exists()
    # the figure: drawn, and the same records draw the same bytes
    figure = out / "figures" / CURVES_FIGURE
    first = figure.read_bytes()
    assert len(first) > 10_000
    write_learning_curves(trained, out)
    assert figure.read_bytes() == first
    # the paper's section is the leaderboard's, from the CSV
    assert learning_curves_section(out) in board
    assert learning_curves_section(tmp_path).startswith("(no `learning_curves.csv` yet")
    # the site shows the figure under the headline table
    site = tmp_path / "site"
    argv = ["--runs", str(runs), "--training", str(trained), "--out", str(out), "--site", str(site)]
    assert leaderboard.main(argv) == 0
    assert (site / "images" / CURVES_FIGURE).read_bytes() == first
    assert f'<img src="images/{CURVES_FIGURE}"' in (site / "index.html").read_text(encoding="utf-8")


def test_a_seed_kept_twice_with_different_records_is_a_user_error(trained, tmp_path, capsys):
    training = tmp_path / "training"
    shutil.copytree(trained / "ppo", training / "ppo", ignore=shutil.ignore_patterns("seed1"))
    shutil.copytree(training / "ppo", training / "ppo" / "seed0")  # --ship and --keep of one run
    assert set(learning_curves(training)["seed"]) == {0}  # counted once
    assert learning_curves(training).equals(
        learning_curves(trained).query("baseline == 'ppo' and seed == 0").reset_index(drop=True)
    )
    validation = training / "ppo" / "seed0" / "validation.csv"
    validation.write_text("\n".join(validation.read_text().splitlines()[:-1]) + "\n")  # one row fewer
    runs = tmp_path / "runs"
    assert run_main(["--baseline", "random_bounce", "--layout", "a320_cell", "--max-steps", "5",
                     "--episodes", "1", "--out", str(runs)])[0] == 0  # fmt: skip
    assert leaderboard.main(["--runs", str(runs), "--training", str(training), "--out", str(tmp_path)]) == 2
    error = capsys.readouterr().err
    assert "both hold seed 0 of ppo with different validation.csv" in error and "Traceback" not in error


def test_committed_records_say_where_each_baseline_validated_and_what_its_steps_count():
    """The kept runs of the suite and team learners: validated on cabin-v1-val, not on what they trained
    on; the team's steps are every robot's, after a policy it started from."""
    curves = learning_curves(ROOT / "results" / "training")
    suite = curves[curves["baseline"] == "ppo_gail_suite"]
    config = json.loads((ROOT / "results/training/ppo_gail_suite/config.json").read_text())
    assert set(suite["validation_layouts"]) == {"cabin-v1-val (10 layouts)"}
    assert list(suite["env_steps"]) == list(
        suite["iteration"] * config["num_envs"] * config["num_steps_per_env"]
    )
    team = curves[curves["baseline"] == "ppo_gail_team"]
    assert set(team["validation_layouts"]) == {"cabin-v1-val (5 layouts)"}
    assert all("4 robots per team step" in note and "init_policy" in note for note in team["env_steps_note"])
