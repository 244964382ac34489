"""The headline score and the statistics behind the headline table: hand-computed episodes, and
the property a reader relies on: stopping early with floor left dirty never beats cleaning it."""

import json
import math

import numpy as np
import pandas as pd
import pytest
from scipy import stats as scipy_stats

from cabinbench.agents import Baseline
from cabinbench.episodes import run_episode
from cabinbench.leaderboard.headline import headline_score, staged_training_cost, success_share, training_cost
from cabinbench.leaderboard.predictors import predictor_finding, predictor_tests
from cabinbench.metrics import clean_score
from cabinbench.stats import holm, partial_spearman, reach_time, t_interval


def test_clean_score_by_hand():
    # cleaned at 60 s of a 150 s limit: 1 - 60 / 300
    assert clean_score(0.99, 60.0, 150.0, 0.98) == pytest.approx(0.8)
    # cleaned at the last step meets the other half at 0.5
    assert clean_score(0.98, 150.0, 150.0, 0.98) == pytest.approx(0.5)
    # not cleaned: coverage at the limit over twice the level
    assert clean_score(0.843, None, 150.0, 0.98) == pytest.approx(0.843 / 1.96)
    assert clean_score(0.0, None, 150.0, 0.98) == 0.0


@pytest.mark.parametrize("coverage", [0.0, 0.5, 0.843, 0.9799])
@pytest.mark.parametrize("clean_time", [0.1, 75.0, 150.0])
def test_stopping_early_dirty_never_beats_cleaning(coverage, clean_time):
    assert clean_score(coverage, None, 150.0, 0.98) < clean_score(1.0, clean_time, 150.0, 0.98)


class Stopper(Baseline):
    """Never moves."""

    def act(self, observation, info):
        return np.zeros(2, dtype=np.float32)


def test_ending_early_with_floor_dirty_scores_below_cleaning():
    """Real episodes on a320_cell. The planner cleans the cell. The shipped ``ppo`` reaches every
    goal marker, which ends a sequential episode early, with floor left dirty; a robot that never
    moves covers only the floor under its start. Neither succeeds, and both score below 0.5."""
    planner, _ = run_episode("boustrophedon", "a320_cell", seed=0)
    early, _ = run_episode("ppo", "a320_cell", seed=0)
    stopped, _ = run_episode("tests.test_headline:Stopper", "a320_cell", seed=0, env_kwargs={"max_steps": 30})
    assert planner["success"] and planner["clean_time"] <= planner["time"] <= planner["time_limit"]
    assert planner["clean_score"] == pytest.approx(1 - planner["clean_time"] / (2 * planner["time_limit"]))
    assert early["goals_reached"] and early["time"] < planner["time"] and early["coverage"] < 0.98
    for dirty in (early, stopped):
        assert not dirty["success"] and dirty["clean_time"] is None
        assert dirty["clean_score"] == pytest.approx(dirty["coverage"] / (2 * 0.98))
        assert dirty["clean_score"] < 0.5 <= planner["clean_score"]


def test_reach_metrics_g_and_t_by_hand():
    summary = reach_time([10.0, None, 30.0, None])  # G90 = 2 of 4, T90 = mean of the two
    assert summary.reached == 0.5 and summary.mean == 20.0 and summary.n == 2


def test_t_interval_by_hand():
    values = [0.927, 0.877, 0.526]
    mean, sd = np.mean(values), np.std(values, ddof=1)
    half = scipy_stats.t.ppf(0.975, 2) * sd / math.sqrt(3)
    summary = t_interval(values)
    assert (summary.mean, summary.low, summary.high, summary.n) == pytest.approx(
        (mean, mean - half, mean + half, 3)
    )
    assert summary.low < min(values)  # it reaches beyond the seeds, as a bootstrap over three cannot
    assert math.isnan(t_interval([0.5]).low)


def test_holm_by_hand():
    adjusted = holm([0.01, 0.04, 0.03, math.nan, 0.005])
    assert adjusted[:3] == pytest.approx([0.03, 0.06, 0.06]) and math.isnan(adjusted[3])
    assert adjusted[4] == pytest.approx(0.02)


def test_partial_spearman_removes_what_the_control_explains():
    rng = np.random.default_rng(0)
    area = rng.normal(size=200)
    complexity = area + 0.3 * rng.normal(size=200)  # grows with area
    coverage = -area + 0.3 * rng.normal(size=200)  # harder because larger, not because complex
    assert scipy_stats.spearmanr(complexity, coverage).statistic < -0.7
    rho, p = partial_spearman(complexity, coverage, area)
    assert abs(rho) < 0.2 and p > 0.01
    own = -complexity + 0.3 * rng.normal(size=200)  # complexity itself matters
    assert partial_spearman(complexity, own, area)[0] < -0.5


def _episodes(scores: dict[tuple[str, str], list[float]]) -> pd.DataFrame:
    return pd.DataFrame(
        [
            {"policy": policy, "layout": layout, "clean_score": value, "success": value >= 0.5}
            for (policy, layout), values in scores.items()
            for value in values
        ]
    )


def test_headline_interval_counts_seeds_or_layouts():
    one_policy = _episodes({("shipped", f"L{i}"): [i / 10] for i in range(8)})
    summary = headline_score(one_policy)
    assert summary.n == 8 and summary.low <= summary.mean <= summary.high  # bootstrap over layouts
    seeds = _episodes({(f"seed{s}", f"L{i}"): [0.3 + 0.1 * s + i / 100] for s in range(3) for i in range(8)})
    summary = headline_score(seeds)
    assert summary.n == 3 and 0.0 <= summary.low < summary.mean < summary.high <= 1.0  # t over seeds
    assert success_share(seeds).n == 3


def test_a_policy_started_from_another_costs_that_ones_training_too(tmp_path):
    """The team's seeds each grow from their own stage-1 run, and both of those from the shipped
    ``ppo_gail``: per seed the three runs add up; over all runs the shared start counts once."""
    training = tmp_path / "results" / "training"

    def run(folder, steps, seconds, init_policy=None):
        folder.mkdir(parents=True)
        (folder / "metrics.csv").write_text(f"iteration,timesteps,train_time\n1,1,0.5\n2,{steps},{seconds}\n")
        (folder / "config.json").write_text(json.dumps({"init_policy": init_policy}))

    run(training / "ppo_gail", 100, 10.0)
    run(training / "ppo_gail" / "seed1", 90, 9.0)
    for seed, (steps, seconds) in enumerate([(20, 2.0), (30, 3.0)]):
        run(tmp_path / "results" / "training_runs" / f"k2_seed{seed}", steps, seconds, "ppo_gail")
    run(training / "ppo_gail_team", 5, 1.0, "results/training_runs/k2_seed0/policy.pt")
    run(training / "ppo_gail_team" / "seed1", 7, 1.5, "results/training_runs/k2_seed1/policy.pt")

    team = training_cost(training, "ppo_gail_team")
    assert (team.runs, team.env_steps, team.wall_clock_s) == (2, (125 + 137) / 2, (13.0 + 14.5) / 2)
    assert team.all_runs_wall_clock_s == 1.0 + 1.5 + 2.0 + 3.0 + 10.0
    alone = training_cost(training, "ppo_gail")  # no init_policy: each run alone
    assert (alone.runs, alone.env_steps, alone.all_runs_wall_clock_s) == (2, 95.0, 19.0)
    run(
        training / "looped", 4, 1.0, "results/training/looped/policy.pt"
    )  # a start naming itself ends the chain
    assert training_cost(training, "looped").env_steps == 4.0


def test_a_pair_trained_in_stages_costs_both_stages_a_seed(tmp_path):
    """The study's pair: each seed's cleaning and tracking runs add up, and its seeds are the runs."""
    training = tmp_path / "training"
    for stage, steps, seconds in (("cleaning", 60, 6.0), ("tracking", 20, 2.0)):
        for extra, folder in enumerate([training / f"pair_{stage}", training / f"pair_{stage}" / "seed1"]):
            folder.mkdir(parents=True)
            (folder / "metrics.csv").write_text(
                f"iteration,timesteps,train_time\n1,{steps},{seconds + extra}\n"
            )
    cost = staged_training_cost(training, "pair")
    assert (cost.runs, cost.env_steps, cost.wall_clock_s) == (2, 80.0, 6.5 + 2.5)
    assert cost.all_runs_wall_clock_s == 6.0 + 7.0 + 2.0 + 3.0
    assert staged_training_cost(training, "unstaged") is None


def test_the_finding_may_say_no():
    rng = np.random.default_rng(1)
    layouts = [f"L{i}" for i in range(30)]
    area = pd.Series(rng.uniform(10, 40, 30), index=layouts)
    features = pd.DataFrame(
        {
            "complexity": area / 100 + rng.normal(0, 0.01, 30),
            "coverable_area": area,
            "obstacles": rng.integers(10, 50, 30),
            "seat_rows": rng.integers(5, 20, 30).astype(float),
        },
        index=layouts,
    )
    scores = {"planner": pd.DataFrame({"coverage": 1 - area / 100 + rng.normal(0, 0.005, 30)}, index=layouts)}
    table = predictor_tests(scores, features)
    sentence = predictor_finding(table, "toy")
    assert "does not predict beyond coverable area" in sentence
