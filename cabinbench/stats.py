"""Statistics over episodes: the one place where summaries and confidence intervals are computed.

Used by ``python -m cabinbench.run`` (its table and ``--json``) and by the leaderboard.

- :func:`mean_ci`: the mean and a 95% percentile-bootstrap confidence interval
  (``scipy.stats.bootstrap``, 9,999 resamples, a fixed seed so that the leaderboard is
  reproducible byte for byte). One episode has no interval (both bounds NaN); a constant sample
  has the degenerate interval [c, c]. Percentile rather than BCa because BCa is undefined for
  the near-constant samples this benchmark produces (e.g. ``success`` all true).
- :func:`iqm`: the interquartile mean, ``scipy.stats.trim_mean(x, 0.25)`` (robust to the odd
  stuck episode, as recommended by Agarwal et al. 2021).
- :func:`reach_time`: for ``t90``/``t95``/``t99``, which are null in episodes that never reached
  the threshold: the mean (and interval) over the episodes that did, plus the fraction that did.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from .metrics import COVERAGE_THRESHOLDS

CONFIDENCE = 0.95
RESAMPLES = 9_999
BOOTSTRAP_SEED = 0
REACH_TIMES = tuple(f"t{round(threshold * 100)}" for threshold in COVERAGE_THRESHOLDS)  # t90, t95, t99


@dataclass(frozen=True)
class Summary:
    """A sample's mean with its 95% interval; ``reached`` is set only for threshold times."""

    mean: float
    low: float
    high: float
    n: int
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


def mean_ci(values) -> Summary:
    """Mean and 95% percentile-bootstrap interval of a sample (booleans count as 0/1)."""
    sample = _numbers(values)
    n = len(sample)
    if n == 0:
        return Summary(math.nan, math.nan, math.nan, 0)
    mean = float(sample.mean())
    if n == 1:
        return Summary(mean, math.nan, math.nan, 1)
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
    """The summary a metric gets everywhere: threshold times (``t90`` ...) via :func:`reach_time`,
    everything else via :func:`mean_ci`."""
    return reach_time(values) if metric in REACH_TIMES else mean_ci(values)
