"""Each statistical definition of cabinbench/stats.py against hand-checkable cases and known values,
and the rule that an interval never runs over identical episodes, on the committed records."""

import math
from pathlib import Path

import numpy as np
import pytest
from scipy import stats as scipy_stats

from cabinbench.records import read_records
from cabinbench.stats import (
    Summary,
    distinct_episodes,
    mean_ci,
    performance_profile,
    probability_of_improvement,
    spearman,
    stratified_bootstrap,
    success_rate,
    summarize,
    summarize_cells,
    t_interval,
)

RUNS = Path(__file__).resolve().parents[1] / "results" / "runs"


@pytest.mark.parametrize(
    ("successes", "n", "low", "high"),
    [(20, 20, 0.8389, 1.0), (10, 20, 0.2993, 0.7007), (0, 20, 0.0, 0.1611), (19, 20, 0.7639, 0.9911)],
)
def test_success_rate_has_the_wilson_interval(successes, n, low, high):
    """Known Wilson 95% intervals: a 20/20 success is [0.839, 1.0], not 1.00 ± 0.00."""
    rate = success_rate([True] * successes + [False] * (n - successes))
    assert rate.mean == successes / n and rate.n == n
    assert (rate.low, rate.high) == pytest.approx((low, high), abs=5e-5)
    assert summarize("success", [True] * successes + [False] * (n - successes)) == rate
    assert math.isnan(success_rate([True]).low)  # one unit: no interval


def test_identical_episodes_are_one_unit_on_the_committed_records():
    """boustrophedon from the layout's fixed start repeats one episode under every seed: one unit;
    random_bounce's episodes all differ."""
    fixed_start = lambda records: records[records["suite"].isna()]  # noqa: E731 (the classic suite's are random)
    planner = fixed_start(
        read_records(sorted(RUNS.glob("a320_cell__boustrophedon__sequential__k1__seed*.jsonl")))
    )
    assert len(planner) == 20 and len(distinct_episodes(planner)) == 1
    random = fixed_start(
        read_records(sorted(RUNS.glob("a320_cell__random_bounce__sequential__k1__seed*.jsonl")))
    )
    assert len(distinct_episodes(random)) == len(random) == 20
    # the machine's wall-clock time is no part of an episode's outcome
    assert planner["wall_time"].nunique() > 1


def test_stratified_bootstrap_by_hand():
    # one cell is the plain percentile bootstrap of its episodes
    values = [0.1, 0.4, 0.5, 0.9]
    assert stratified_bootstrap({("s0", "a"): values}) == mean_ci(values)
    # a lone unit has no interval
    lone = stratified_bootstrap({("s0", "a"): [0.7]})
    assert lone.mean == 0.7 and math.isnan(lone.low)
    # two layouts, constant within each: the layout draw alone decides, estimates 0, 0.5 or 1
    layouts = stratified_bootstrap({("s0", "a"): [0.0, 0.0], ("s0", "b"): [1.0, 1.0]})
    assert (layouts.mean, layouts.low, layouts.high, layouts.n) == (0.5, 0.0, 1.0, 4)
    # three training seeds on one layout: each seed drawn three times has probability 1/27 > 2.5%
    seeds = stratified_bootstrap({("s0", "a"): [0.2], ("s1", "a"): [0.5], ("s2", "a"): [0.8]})
    assert (seeds.mean, seeds.low, seeds.high) == pytest.approx((0.5, 0.2, 0.8))
    # the mean is over seeds of the mean over layouts of per-layout means, whatever the cell sizes
    unequal = stratified_bootstrap(
        {("s0", "a"): [0.0, 0.0, 0.0, 1.0], ("s0", "b"): [1.0], ("s1", "a"): [0.5], ("s1", "b"): [0.5, 0.5]}
    )
    assert unequal.mean == pytest.approx(((0.25 + 1.0) / 2 + 0.5) / 2)
    assert unequal == stratified_bootstrap(
        {("s0", "a"): [0.0, 0.0, 0.0, 1.0], ("s0", "b"): [1.0], ("s1", "a"): [0.5], ("s1", "b"): [0.5, 0.5]}
    )  # a fixed seed: the same records give the same bounds
    with pytest.raises(ValueError, match="no episodes"):
        stratified_bootstrap({("s0", "a"): [1.0], ("s1", "b"): [1.0]})


def test_stratified_bootstrap_with_layouts_nested_in_the_seeds():
    """Each seed on layouts of its own (a suite learner's training layouts): the mean over seeds of each
    seed's mean over its layouts, and each seed's layouts drawn apart."""
    own = {("s0", "a"): [0.0], ("s0", "b"): [1.0], ("s1", "c"): [0.2], ("s1", "d"): [0.4, 0.6]}
    nested = stratified_bootstrap(own, own_layouts=True)
    assert (nested.mean, nested.n) == (pytest.approx(((0.0 + 1.0) / 2 + (0.2 + 0.5) / 2) / 2), 5)
    assert 0.0 <= nested.low < nested.mean < nested.high <= 1.0
    # seeds that share their layouts still resample alike whether drawn as one sample or apart
    one_seed = {("s0", "a"): [0.0], ("s0", "b"): [1.0]}
    assert stratified_bootstrap(one_seed, own_layouts=True).mean == stratified_bootstrap(one_seed).mean
    with pytest.raises(ValueError, match="no episodes"):
        stratified_bootstrap({("s0", "a"): []}, own_layouts=True)


def test_summarize_cells():
    # several training seeds: each seed's own rate, then a t interval over the seeds
    cells = {("s0", "a"): [True, True], ("s1", "a"): [True, False]}
    unclipped = t_interval([1.0, 0.5])
    assert summarize_cells("success", cells) == Summary(
        0.75, max(0.0, unclipped.low), min(1.0, unclipped.high), 2
    )
    # one seed: a Wilson interval over its episodes
    assert summarize_cells(
        "success", {("s0", "a"): [True, False], ("s0", "b"): [True, True]}
    ) == success_rate([True, False, True, True])
    times = summarize_cells(
        "t90", {("s0", "a"): [10.0, None], ("s1", "a"): [None, None], ("s2", "a"): [30.0, 50.0]}
    )
    # seed s1 never reached 90 %: the seeds that did count, and the pooled share that reached it
    assert times.reached == 0.5 and times.mean == pytest.approx((10.0 + 40.0) / 2) and times.n == 2
    assert summarize_cells("coverage", {("s0", "a"): [0.5, 0.7]}) == mean_ci([0.5, 0.7])
    seeds = summarize_cells("coverage", {("s0", "a"): [0.2], ("s1", "a"): [0.5], ("s2", "a"): [0.8]})
    assert seeds.n == 3 and seeds.low < 0.2 and seeds.high > 0.8  # beyond the seeds observed


def test_performance_profile_by_hand():
    profile = performance_profile([0.2, 0.5, 0.9], [0.0, 0.2, 0.5, 0.95])
    assert profile.tolist() == pytest.approx([1.0, 2 / 3, 1 / 3, 0.0])  # strictly above each level


def test_probability_of_improvement_by_hand():
    assert probability_of_improvement([[2.0, 3.0]], [[0.0, 1.0]]).mean == 1.0
    assert probability_of_improvement([[1.0, 2.0]], [[0.0, 3.0]]).mean == 0.5  # 2 of 4 pairs
    assert probability_of_improvement([[1.0]], [[1.0]]).mean == 0.5  # a tie counts half
    # averaged over layouts, interval over layouts
    two = probability_of_improvement([[1.0], [0.0]], [[0.0], [0.0, 1.0]])
    assert two.mean == pytest.approx((1.0 + 0.25) / 2) and two.n == 2
    assert (two.low, two.high) == (0.25, 1.0)
    # P(X > Y) + P(Y > X) = 1
    rng = np.random.default_rng(3)
    x = [rng.random(5) for _ in range(4)]
    y = [rng.random(3) for _ in range(4)]
    assert probability_of_improvement(x, y).mean + probability_of_improvement(y, x).mean == pytest.approx(1.0)


def test_spearman_by_hand_and_against_scipy():
    rho = spearman([1, 2, 3, 4, 5], [2, 1, 4, 3, 5])
    assert rho.mean == pytest.approx(0.8)  # Σd² = 4: 1 - 6·4 / (5·24)
    assert math.isnan(rho.low)  # five pairs: too few for a bootstrap interval
    ten = spearman(range(10), [1, 0, 3, 2, 5, 4, 7, 6, 9, 8])
    assert ten.mean == pytest.approx(1 - 6 * 10 / (10 * 99))  # Σd² = 10
    assert ten.low < ten.mean <= ten.high <= 1.0 and ten == spearman(
        range(10), [1, 0, 3, 2, 5, 4, 7, 6, 9, 8]
    )
    perfect = spearman(range(12), range(0, 120, 10))
    assert (perfect.mean, perfect.low, perfect.high) == (1.0, 1.0, 1.0)
    rng = np.random.default_rng(7)
    x, y = rng.random(30), rng.random(30)
    noise = spearman(x, y)
    assert noise.mean == pytest.approx(scipy_stats.spearmanr(x, y).statistic)
    assert noise.low < 0 < noise.high  # independent samples: the interval holds zero
    assert math.isnan(spearman([1, 2], [3, 4]).mean) and math.isnan(spearman([1, 1, 1], [1, 2, 3]).mean)


def test_stratified_difference_pairs_the_training_seeds():
    from cabinbench.stats import stratified_bootstrap, stratified_difference

    train = {
        (seed, f"t{layout}"): [0.5 + 0.1 * seed + 0.01 * layout] for seed in range(3) for layout in range(5)
    }
    test = {
        (seed, f"h{layout}"): [0.4 + 0.1 * seed - 0.01 * layout] for seed in range(3) for layout in range(4)
    }
    gap = stratified_difference(train, test)
    assert gap.mean == pytest.approx(stratified_bootstrap(test).mean - stratified_bootstrap(train).mean)
    # a seed scores the same offset on both sides: pairing the seeds cancels it, so the gap's interval is
    # narrower than either side's
    assert gap.low < gap.mean < gap.high
    assert gap.high - gap.low < stratified_bootstrap(train).high - stratified_bootstrap(train).low
    # other seeds on one side: a difference without an interval
    unpaired = stratified_difference(
        train, {(seed + 1, layout): cell for (seed, layout), cell in test.items()}
    )
    assert math.isnan(unpaired.low) and unpaired.mean == pytest.approx(gap.mean)
    # the train side's layouts nested in its seeds (each seed its own): paired as before, the mean as by hand
    own_train = {(seed, f"t{seed}-{layout}"): cell for (seed, layout), cell in train.items()}
    nested = stratified_difference(own_train, test, x_own_layouts=True)
    expected = stratified_bootstrap(test).mean - stratified_bootstrap(own_train, own_layouts=True).mean
    assert nested.mean == pytest.approx(expected) == pytest.approx(gap.mean)
    assert nested.low < nested.mean < nested.high
