"""Statistics over episodes: the one place where summaries and confidence intervals are defined.

Used by ``python -m cabinbench.run`` (its table and ``--json``) and by the leaderboard (its
classic table and its suites section). Every interval is a 95% interval; every resampling uses a
fixed seed, so the same records give byte-identical reports.

What is a unit (the rule against intervals over identical episodes). An interval is computed over
*distinct* episodes only: two episodes of a row with the same value of every recorded outcome
(:data:`OUTCOME`: every metric but ``wall_time``) are one episode repeated and count once
(:func:`distinct_episodes`). A deterministic baseline run from one fixed start gives the same
episode under every seed, so its row is one unit: it has a mean and no interval, and the tables
say "deterministic: n identical episodes". Two genuinely different episodes agreeing on every
float of every metric is not a coincidence worth planning for.

- :func:`mean_ci`: the mean and a percentile-bootstrap interval (``scipy.stats.bootstrap``,
  9,999 resamples). One unit has no interval (both bounds NaN); distinct episodes with the same
  value of this metric have the degenerate interval [c, c]. Percentile rather than BCa because
  BCa is undefined for the near-constant samples this benchmark produces.
- :func:`success_rate`: a rate with its Wilson score interval (``scipy.stats.binomtest``): 20
  successes of 20 give [0.839, 1.0], not ``1.00 ± 0.00``.
- :func:`iqm`: the interquartile mean, ``scipy.stats.trim_mean(x, 0.25)`` (Agarwal et al. 2021).
- :func:`reach_time`: for ``t90``/``t95``/``t99``, null in episodes that never reached the
  threshold: the mean (and interval) over the episodes that did, plus the fraction that did.
- :func:`stratified_bootstrap`: a score over several layouts: the mean over layouts of per-layout
  means, with a stratified bootstrap interval that resamples layouts, and episodes within each
  layout, as rliable recommends (several training seeds are resampled too where it is called on
  them: the generalisation gap).
- :func:`across_seeds` and :func:`t_interval`: over training seeds, each seed's own value first,
  then a Student-t interval over the seeds (n = seeds), honest for the few seeds a benchmark has.
- :func:`stratified_difference`: the difference of two such scores over the same training seeds on
  different layouts (a generalisation gap), the seeds resampled jointly.
- :func:`performance_profile`: the fraction of layouts whose score is above each level.
- :func:`probability_of_improvement`: P(X > Y), per layout the Mann-Whitney probability that an
  episode of X beats one of Y (ties count half), averaged over layouts, with a bootstrap interval
  over layouts.
- :func:`spearman`: Spearman's rank correlation with a bootstrap interval over (x, y) pairs (from
  ten pairs on).
- :func:`headline`: a method's headline score on a set of layouts (:mod:`cabinbench.headline`).
- :func:`partial_spearman` and :func:`holm`: complexity as a predictor of difficulty, tested.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from cabinbench.metrics import FRACTIONS, METRICS, RATES, REACH_TIMES, TEAM_METRICS

if TYPE_CHECKING:
    import pandas as pd

CONFIDENCE = 0.95
RESAMPLES = 9_999
BOOTSTRAP_SEED = 0
MIN_CORRELATION_PAIRS = 10  # fewer pairs: a rank correlation without interval (see spearman)
# what an episode's outcome is: every metric but the machine's wall-clock time
OUTCOME = tuple(name for name in (*METRICS, *TEAM_METRICS) if name != "wall_time")


@dataclass(frozen=True)
class Summary:
    """A sample's mean with its 95% interval; ``reached`` is set only for threshold times."""

    mean: float
    low: float
    high: float
    n: int  # distinct units the interval is computed over
    reached: float | None = None  # fraction of episodes that reached the threshold (t90 ...)

    def as_dict(self) -> dict:
        """JSON-ready: NaN becomes None."""
        values = {"mean": self.mean, "ci_low": self.low, "ci_high": self.high, "n": self.n}
        if self.reached is not None:
            values["reached"] = self.reached
        return {
            key: None if isinstance(value, float) and math.isnan(value) else value
            for key, value in values.items()
        }


def _numbers(values) -> np.ndarray:
    return np.asarray(list(values), dtype=float)


def distinct_episodes(episodes: pd.DataFrame, within: Sequence[str] = ()) -> pd.DataFrame:
    """The episodes with every repeat of an earlier episode's outcome (:data:`OUTCOME`) dropped;
    ``within``: columns that tell strata apart (the same outcome in two strata is kept twice)."""
    columns = [*within, *(name for name in OUTCOME if name in episodes.columns)]
    return episodes.loc[~episodes[columns].astype(str).duplicated()]


def _without_interval(sample: np.ndarray) -> Summary:
    """No unit or one: the mean (NaN for none) and no interval."""
    return Summary(float(sample.mean()) if len(sample) else math.nan, math.nan, math.nan, len(sample))


def mean_ci(values) -> Summary:
    """Mean and 95% percentile-bootstrap interval of a sample of distinct units (booleans count
    as 0/1)."""
    sample = _numbers(values)
    n = len(sample)
    if n < 2:
        return _without_interval(sample)
    mean = float(sample.mean())
    if np.ptp(sample) == 0:  # every resample is the same: skip scipy's degenerate-data warning
        return Summary(mean, mean, mean, n)
    from scipy import stats  # here, not at the top: 0.8 s of every command's start-up

    result = stats.bootstrap(
        (sample,),
        np.mean,
        n_resamples=RESAMPLES,
        confidence_level=CONFIDENCE,
        method="percentile",
        vectorized=True,
        rng=np.random.default_rng(BOOTSTRAP_SEED),
    )
    interval = result.confidence_interval
    return Summary(mean, float(interval.low), float(interval.high), n)


def success_rate(values) -> Summary:
    """The rate of true values with its 95% Wilson score interval; one unit has no interval."""
    sample = _numbers(values)
    n = len(sample)
    if n < 2:
        return _without_interval(sample)
    successes = int(sample.sum())
    from scipy import stats

    interval = stats.binomtest(successes, n).proportion_ci(confidence_level=CONFIDENCE, method="wilson")
    return Summary(successes / n, float(interval.low), float(interval.high), n)


def iqm(values) -> float:
    """Interquartile mean: the mean of the middle 50% of the sample."""
    sample = _numbers(values)
    from scipy import stats

    return float(stats.trim_mean(sample, 0.25)) if len(sample) else math.nan


def reach_time(values) -> Summary:
    """Threshold times with nulls (None/NaN = never reached): summary over the episodes that
    reached it, and the fraction that did."""
    sample = _numbers(np.nan if value is None else value for value in values)
    reached = sample[~np.isnan(sample)]
    summary = mean_ci(reached)
    fraction = len(reached) / len(sample) if len(sample) else math.nan
    return Summary(summary.mean, summary.low, summary.high, summary.n, reached=fraction)


def summarize(metric: str, values) -> Summary:
    """The summary a metric gets over one sample of distinct episodes: threshold times (``t90``
    ...) via :func:`reach_time`, rates via :func:`success_rate`, everything else via
    :func:`mean_ci`."""
    if metric in REACH_TIMES:
        return reach_time(values)
    return success_rate(values) if metric in RATES else mean_ci(values)


def summarize_cells(metric: str, cells: Mapping[tuple[str, str], Sequence]) -> Summary:
    """The summary a metric gets over (training seed, layout) cells of distinct episodes. Several
    training seeds: each seed's own value first, then a t interval over the seeds
    (:func:`across_seeds`, n = seeds). One seed: one cell is :func:`summarize`; several layouts are
    :func:`stratified_bootstrap`, except rates, whose Wilson interval is over the pooled episodes,
    and threshold times, whose interval runs over the cells where some episode reached the
    threshold (``reached``: the pooled fraction)."""
    if len({policy for policy, _ in cells}) > 1:
        return across_seeds(metric, cells)
    if len(cells) == 1 or metric in RATES:
        return summarize(metric, [value for cell in cells.values() for value in cell])
    if metric not in REACH_TIMES:
        return stratified_bootstrap(cells)
    pooled = _numbers(np.nan if value is None else value for cell in cells.values() for value in cell)
    reached = {
        key: [value for value in cell if value is not None and not math.isnan(value)]
        for key, cell in cells.items()
    }
    reached = {key: cell for key, cell in reached.items() if cell}
    layouts = {layout for _, layout in reached}
    policies = {policy for policy, _ in reached}
    complete = {
        (policy, layout): reached[policy, layout]
        for policy in policies
        for layout in layouts
        if all((other, layout) in reached for other in policies)
    }
    summary = stratified_bootstrap(complete) if complete else Summary(math.nan, math.nan, math.nan, 0)
    fraction = float((~np.isnan(pooled)).mean())
    return Summary(summary.mean, summary.low, summary.high, summary.n, reached=fraction)


def across_seeds(metric: str, cells: Mapping[tuple[str, str], Sequence]) -> Summary:
    """Each training seed's value of ``metric`` over its own layouts (:func:`summarize_cells`; a
    rate is the seed's own rate), then the mean over seeds with a Student-t interval (n = seeds):
    a bootstrap over three seeds cannot reach beyond the seeds observed. A fraction's interval is
    clipped to [0, 1]; threshold times keep the pooled fraction of episodes that reached the
    threshold."""
    policies = sorted({policy for policy, _ in cells})
    per_seed = [
        summarize_cells(metric, {key: cell for key, cell in cells.items() if key[0] == policy}).mean
        for policy in policies
    ]
    summary = t_interval([value for value in per_seed if not math.isnan(value)])
    if metric in FRACTIONS:  # a fraction's interval stays in [0, 1]
        low, high = (min(1.0, max(0.0, bound)) for bound in (summary.low, summary.high))
        return Summary(summary.mean, low, high, summary.n)
    if metric not in REACH_TIMES:
        return summary
    pooled = _numbers(np.nan if value is None else value for cell in cells.values() for value in cell)
    return Summary(
        summary.mean, summary.low, summary.high, summary.n, reached=float((~np.isnan(pooled)).mean())
    )


def _percentile_interval(estimates: np.ndarray) -> tuple[float, float]:
    tail = (1 - CONFIDENCE) / 2 * 100
    low, high = np.nanpercentile(estimates, [tail, 100 - tail])
    return float(low), float(high)


def _resample_weights(rng: np.random.Generator, size: int) -> np.ndarray:
    """(RESAMPLES, size): how often each of ``size`` items is drawn in each resample, over size."""
    return _counts(rng.integers(0, size, (RESAMPLES, size)), size) / size


def _counts(indices: np.ndarray, size: int) -> np.ndarray:
    """(rows, size): how often each of ``0 .. size-1`` occurs in each row of ``indices``."""
    rows = len(indices)
    flat = (np.arange(rows)[:, None] * size + indices).ravel()
    return np.bincount(flat, minlength=rows * size).reshape(rows, size).astype(float)


def stratified_bootstrap(
    cells: Mapping[tuple[str, str], Sequence[float]], own_layouts: bool = False
) -> Summary:
    """Mean over training seeds of the mean over layouts of per-layout means, with a stratified
    bootstrap interval.

    ``cells`` maps (training seed or policy, layout) to the values of that cell's distinct
    episodes. Each resample draws the seeds with replacement, the layouts with replacement and the
    episodes of each cell with replacement. Layouts are crossed with seeds (every seed has every
    layout, and one draw of them serves every seed), or with ``own_layouts`` nested in them (each
    seed has layouts of its own, e.g. those its run trained on, drawn apart). One cell is
    :func:`mean_ci`; a single unit in all has no interval. ``n`` counts the distinct episodes.
    """
    values = _checked_cells(cells, own_layouts)
    if len(values) == 1:
        return mean_ci(next(iter(values.values())))
    rng = np.random.default_rng(BOOTSTRAP_SEED)
    if own_layouts:
        mean, per_seed = _nested_seed_estimates(values, rng)
        estimates = np.einsum("bp,bp->b", _resample_weights(rng, per_seed.shape[1]), per_seed)
    else:
        mean, resampled = _resampled_cells(values, rng)
        seed_weights = _resample_weights(rng, resampled.shape[1])
        layout_weights = _resample_weights(rng, resampled.shape[2])
        estimates = np.einsum("bp,bpl,bl->b", seed_weights, resampled, layout_weights)
    return Summary(mean, *_percentile_interval(estimates), sum(len(cell) for cell in values.values()))


def _checked_cells(cells: Mapping[tuple[str, str], Sequence[float]], own_layouts: bool) -> dict:
    """The cells as arrays; a ValueError where a cell has no episodes, or, with layouts crossed with seeds,
    a seed lacks a layout."""
    if not own_layouts:
        policies = sorted({policy for policy, _ in cells})
        layouts = sorted({layout for _, layout in cells})
        missing = [(p, layout) for p in policies for layout in layouts if (p, layout) not in cells]
        if missing:
            raise ValueError(f"stratified_bootstrap: no episodes for (seed, layout) {missing[0]}")
    values = {key: _numbers(cell) for key, cell in cells.items()}
    if any(len(cell) == 0 for cell in values.values()):
        raise ValueError("stratified_bootstrap: a (seed, layout) cell has no episodes")
    return values


def _nested_seed_estimates(values: Mapping[tuple[str, str], np.ndarray], rng) -> tuple[float, np.ndarray]:
    """Layouts nested in seeds: the mean over seeds of each seed's mean over its own layouts of per-cell
    means, and (RESAMPLES, seeds): each seed's mean over its layouts drawn with replacement of its cells'
    means over their episodes drawn with replacement (seeds sorted)."""
    policies = sorted({policy for policy, _ in values})
    means, per_seed = [], np.empty((RESAMPLES, len(policies)))
    for i, p in enumerate(policies):
        own = [values[key] for key in sorted(key for key in values if key[0] == p)]
        cells = np.stack(
            [cell[rng.integers(0, len(cell), (RESAMPLES, len(cell)))].mean(axis=1) for cell in own]
        )
        per_seed[:, i] = np.einsum("bl,lb->b", _resample_weights(rng, len(own)), cells)
        means.append(np.mean([cell.mean() for cell in own]))
    return float(np.mean(means)), per_seed


def _resampled_cells(values: Mapping[tuple[str, str], np.ndarray], rng) -> tuple[float, np.ndarray]:
    """The mean over seeds and layouts of per-cell means, and (RESAMPLES, seeds, layouts): each cell's
    mean over its episodes drawn with replacement (seeds and layouts sorted)."""
    policies = sorted({policy for policy, _ in values})
    layouts = sorted({layout for _, layout in values})
    means = np.array([[values[p, layout].mean() for layout in layouts] for p in policies])
    resampled = np.empty((RESAMPLES, len(policies), len(layouts)))
    for i, p in enumerate(policies):
        for j, layout in enumerate(layouts):
            cell = values[p, layout]
            resampled[:, i, j] = cell[rng.integers(0, len(cell), (RESAMPLES, len(cell)))].mean(axis=1)
    return float(means.mean()), resampled


def stratified_difference(
    x: Mapping[tuple[str, str], Sequence[float]],
    y: Mapping[tuple[str, str], Sequence[float]],
    x_own_layouts: bool = False,
) -> Summary:
    """The :func:`stratified_bootstrap` score of ``y`` minus that of ``x``: the same training seeds on two
    sets of layouts (a generalisation gap: test minus train), ``x``'s layouts nested in its seeds with
    ``x_own_layouts``. Each resample draws the seeds once for both (a seed's two scores are paired), and the
    layouts and episodes of each side apart. Without the same seeds on both sides (or with one cell a side)
    the difference has no interval. ``n`` counts both sides' distinct episodes."""
    sides = [_checked_cells(x, x_own_layouts), _checked_cells(y, False)]
    seeds = [sorted({policy for policy, _ in side}) for side in sides]
    n = sum(len(cell) for side in sides for cell in side.values())
    rng = np.random.default_rng(BOOTSTRAP_SEED)
    if x_own_layouts:
        x_mean, x_seeds = _nested_seed_estimates(sides[0], rng)
    else:
        x_mean, x_cells = _resampled_cells(sides[0], rng)
    y_mean, y_cells = _resampled_cells(sides[1], rng)
    if seeds[0] != seeds[1] or any(len(side) == 1 for side in sides):
        return Summary(y_mean - x_mean, math.nan, math.nan, n)
    seed_weights = _resample_weights(rng, len(seeds[0]))
    if x_own_layouts:
        y_layouts = _resample_weights(rng, y_cells.shape[2])
        x_estimates = np.einsum("bp,bp->b", seed_weights, x_seeds)
    else:
        x_layouts, y_layouts = (_resample_weights(rng, cells.shape[2]) for cells in (x_cells, y_cells))
        x_estimates = np.einsum("bp,bpl,bl->b", seed_weights, x_cells, x_layouts)
    estimates = np.einsum("bp,bpl,bl->b", seed_weights, y_cells, y_layouts) - x_estimates
    return Summary(y_mean - x_mean, *_percentile_interval(estimates), n)


def performance_profile(scores, levels) -> np.ndarray:
    """For each level τ, the fraction of ``scores`` (one per layout) above τ."""
    scores = _numbers(scores)
    return np.array([(scores > level).mean() for level in _numbers(levels)])


def _improvement(x: np.ndarray, y: np.ndarray) -> float:
    """P(an episode of x beats one of y), ties counting half: the Mann-Whitney U over n·m."""
    difference = x[:, None] - y[None, :]
    return float((difference > 0).mean() + 0.5 * (difference == 0).mean())


def probability_of_improvement(
    x_cells: Sequence[Sequence[float]], y_cells: Sequence[Sequence[float]]
) -> Summary:
    """P(X > Y) over layouts: ``x_cells[i]`` and ``y_cells[i]`` are the two baselines' episode
    scores on layout i. The mean over layouts of the per-layout probability, with a percentile
    bootstrap interval that resamples layouts (``n``: layouts)."""
    if len(x_cells) != len(y_cells):
        raise ValueError("probability_of_improvement: give both baselines' scores on the same layouts")
    per_layout = _numbers(_improvement(_numbers(x), _numbers(y)) for x, y in zip(x_cells, y_cells))
    return mean_ci(per_layout)


def _resampled_ranks(values: np.ndarray, draws: np.ndarray) -> np.ndarray:
    """``scipy.stats.rankdata(values[draws], axis=1)`` (ties get their average rank) from counts:
    a drawn value's rank is the number of draws below it plus the mean position among its ties."""
    distinct, index = np.unique(values, return_inverse=True)
    counts = _counts(index[draws], len(distinct))
    average = np.cumsum(counts, axis=1) - counts + (counts + 1) / 2
    return np.take_along_axis(average, index[draws], axis=1)


def spearman(x, y) -> Summary:
    """Spearman's rank correlation of paired samples with a 95% percentile-bootstrap interval
    over pairs (resamples where either side is constant have no correlation and are left out).
    Fewer than three pairs, or a constant side, give NaN. Under :data:`MIN_CORRELATION_PAIRS`
    pairs ρ has no interval: resampling a handful of pairs mostly redraws the same ranking (three
    layouts in perfect order give [1, 1]), an interval that would claim a certainty it lacks."""
    x, y = _numbers(x), _numbers(y)
    if len(x) != len(y):
        raise ValueError("spearman: x and y must be paired")
    n = len(x)
    if n < 3 or np.ptp(x) == 0 or np.ptp(y) == 0:
        return Summary(math.nan, math.nan, math.nan, n)
    from scipy import stats

    rho = float(stats.spearmanr(x, y).statistic)
    if n < MIN_CORRELATION_PAIRS:
        return Summary(rho, math.nan, math.nan, n)
    draws = np.random.default_rng(BOOTSTRAP_SEED).integers(0, n, (RESAMPLES, n))
    ranks_x, ranks_y = _resampled_ranks(x, draws), _resampled_ranks(y, draws)
    ranks_x -= ranks_x.mean(axis=1, keepdims=True)
    ranks_y -= ranks_y.mean(axis=1, keepdims=True)
    spread = np.sqrt((ranks_x**2).sum(axis=1) * (ranks_y**2).sum(axis=1))
    with np.errstate(invalid="ignore", divide="ignore"):
        estimates = (ranks_x * ranks_y).sum(axis=1) / spread  # NaN where a resample is constant
    return Summary(rho, *_percentile_interval(estimates), n)


def t_interval(values) -> Summary:
    """Mean and 95% Student-t interval of a few independent units (training seeds): ``mean ± t(n - 1)
    · sd / sqrt(n)``. Unlike a bootstrap it reaches beyond the observed values, as it must with three
    seeds; one unit has no interval."""
    sample = _numbers(values)
    n = len(sample)
    if n < 2:
        return _without_interval(sample)
    from scipy import stats

    mean = float(sample.mean())
    half = float(stats.t.ppf((1 + CONFIDENCE) / 2, n - 1) * sample.std(ddof=1) / math.sqrt(n))
    return Summary(mean, mean - half, mean + half, n)


def iqm_over_layouts(layout_scores) -> Summary:
    """The IQM of per-layout scores with a percentile-bootstrap interval that resamples layouts
    (``n``: layouts)."""
    sample = _numbers(layout_scores)
    n = len(sample)
    if n < 2 or np.ptp(sample) == 0:
        return Summary(iqm(sample), math.nan, math.nan, n) if n < 2 else Summary(*(3 * [iqm(sample)]), n)
    from scipy import stats

    draws = sample[np.random.default_rng(BOOTSTRAP_SEED).integers(0, n, (RESAMPLES, n))]
    estimates = stats.trim_mean(draws, 0.25, axis=1)
    return Summary(iqm(sample), *_percentile_interval(estimates), n)


def partial_spearman(x, y, control) -> tuple[float, float]:
    """Spearman's ρ of ``x`` and ``y`` with the ranks of ``control`` partialled out, and its
    two-sided p-value (t with n - 3 degrees of freedom): the correlation of the residuals of the
    ranks of x and of y, each regressed on the ranks of ``control``. NaN when a side is constant
    or n < 4."""
    from scipy import stats

    x, y, control = (stats.rankdata(_numbers(values)) for values in (x, y, control))
    n = len(x)
    if n < 4 or min(np.ptp(x), np.ptp(y), np.ptp(control)) == 0:
        return math.nan, math.nan
    design = np.column_stack([np.ones(n), control])
    residuals = [v - design @ np.linalg.lstsq(design, v, rcond=None)[0] for v in (x, y)]
    if min(np.ptp(r) for r in residuals) < 1e-12:
        return math.nan, math.nan
    rho = float(np.corrcoef(*residuals)[0, 1])
    t = rho * math.sqrt((n - 3) / max(1e-300, 1 - rho**2))
    return rho, float(2 * stats.t.sf(abs(t), n - 3))


def one_sided(rho: float, p_two_sided: float, expected_sign: int) -> float:
    """The one-sided p-value of a correlation whose hypothesis names its sign (+1 or -1)."""
    if math.isnan(rho) or math.isnan(p_two_sided):
        return math.nan
    return p_two_sided / 2 if rho * expected_sign > 0 else 1 - p_two_sided / 2


def holm(p_values) -> np.ndarray:
    """Holm's step-down adjusted p-values for a family of tests (NaN stays NaN, out of the family)."""
    p = _numbers(p_values)
    adjusted = np.full(len(p), math.nan)
    tested = np.flatnonzero(~np.isnan(p))
    order = tested[np.argsort(p[tested], kind="stable")]
    running = 0.0
    for rank, index in enumerate(order):
        running = max(running, min(1.0, (len(order) - rank) * p[index]))
        adjusted[index] = running
    return adjusted
