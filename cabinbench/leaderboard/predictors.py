"""Does navigation complexity predict difficulty? Tested with a signed hypothesis, against simple
predictors, and corrected for testing many times.

For every method on a suite and every difficulty measure, each hypothesis names its sign in
advance (:data:`HYPOTHESES`: a harder layout gives lower coverage and a longer T90). Over the
suite's layouts (each layout's mean over its episodes) we report Spearman's ρ of the measure with
each predictor (:data:`PREDICTORS`: the study's normalised complexity, and the simple ones a
reader would try first: coverable area, obstacle count, seat rows) and, for complexity, the
partial ρ with coverable area held fixed (normalised complexity grows with area on these suites,
so a raw ρ may only say "larger cabins are harder"). Each test is one-sided in the hypothesis's
direction; Holm's correction runs over the whole family of tests on the suite. The finding
sentence is generated from the adjusted p-values and may say that complexity does not predict
beyond area.
"""

from __future__ import annotations

import math

import numpy as np
import pandas as pd

from cabinbench.errors import LayoutError
from cabinbench.layouts.complexity import layout_complexity
from cabinbench.layouts.resolve import load_layout
from cabinbench.stats import holm, one_sided, partial_spearman

HYPOTHESES = {"coverage": -1, "t90": +1}  # measure -> the sign a harder layout gives
PREDICTORS = ("complexity", "coverable_area", "obstacles", "seat_rows")
CONTROL = "coverable_area"
ALPHA = 0.05


def layout_features(names) -> pd.DataFrame:
    """One row per layout: the predictors (complexity is the normalised one; seat rows NaN for a
    layout that is not a generated cabin)."""
    rows = []
    for name in sorted(set(names)):
        try:
            layout = load_layout(name)
        except LayoutError:
            continue  # a layout this version cannot build: its rows are left out of the tests
        rows.append(
            {
                "layout": name,
                "complexity": layout_complexity(layout).normalized,
                "coverable_area": layout.coverable_area,
                "obstacles": len(layout.obstacles),
                "seat_rows": float(layout.parameters.get("rows", math.nan)),
            }
        )
    return pd.DataFrame(rows).set_index("layout")


def predictor_tests(per_layout: dict[str, pd.DataFrame], features: pd.DataFrame) -> pd.DataFrame:
    """``per_layout``: method label -> per-layout means (index: layout; columns: the measures of
    :data:`HYPOTHESES`). One row per (method, measure, predictor), partial rows for complexity,
    with ρ, n, the one-sided p-value and the Holm-adjusted one."""
    from scipy import stats

    tests = []
    for label, scores in per_layout.items():
        for measure, sign in HYPOTHESES.items():
            if measure not in scores:
                continue
            data = scores[[measure]].join(features, how="inner").dropna(subset=[measure])
            for predictor in PREDICTORS:
                pair = data[[measure, predictor]].dropna()
                rho, p = math.nan, math.nan
                if len(pair) >= 4 and pair[measure].nunique() > 1 and pair[predictor].nunique() > 1:
                    result = stats.spearmanr(pair[predictor], pair[measure])
                    rho, p = float(result.statistic), float(result.pvalue)
                tests.append(_test(label, measure, predictor, "", rho, p, sign, len(pair)))
            rho, p = partial_spearman(data["complexity"], data[measure], data[CONTROL])
            tests.append(_test(label, measure, "complexity", CONTROL, rho, p, sign, len(data)))
    table = pd.DataFrame(tests)
    if len(table):
        table["p_holm"] = holm(table["p"])
    return table


def _test(label, measure, predictor, control, rho, p_two_sided, sign, n) -> dict:
    return {
        "method": label,
        "measure": measure,
        "predictor": predictor,
        "controlling_for": control,
        "expected_sign": "+" if sign > 0 else "-",
        "rho": rho,
        "n": n,
        "p": one_sided(rho, p_two_sided, sign),
    }


def supported(table: pd.DataFrame) -> pd.DataFrame:
    """The tests whose hypothesis holds after Holm's correction."""
    return table[table["p_holm"] < ALPHA] if len(table) else table


def predictor_finding(table: pd.DataFrame, suite: str) -> str:
    """The finding, in words, from the adjusted p-values."""
    if table.empty or table["p"].isna().all():
        return (
            f"Finding ({suite}): too few layouts or no variation to test whether complexity "
            "predicts difficulty."
        )
    held = supported(table)
    raw = held[(held["predictor"] == "complexity") & (held["controlling_for"] == "")]
    partial = held[(held["predictor"] == "complexity") & (held["controlling_for"] == CONTROL)]
    simple = held[held["predictor"] != "complexity"]
    methods = table["method"].nunique()
    tested = table[(table["predictor"] == "complexity") & (table["controlling_for"] == "")]
    sentence = (
        f"Finding ({suite}, {methods} methods, {len(table)} one-sided tests, Holm-corrected at {ALPHA}): "
        f"normalised complexity predicts difficulty in the hypothesised direction in {len(raw)} of "
        f"{len(tested)} method-measure pairs"
    )
    if len(partial):
        sentence += f", and beyond coverable area in {len(partial)}: " + _pairs(partial)
    else:
        sentence += "; it does not predict beyond coverable area in any"
    if len(simple):
        by_predictor = simple.groupby("predictor").size()
        sentence += ". Simple predictors hold in " + ", ".join(
            f"{count} ({predictor.replace('_', ' ')})" for predictor, count in by_predictor.items()
        )
    return sentence + "."


def _pairs(table: pd.DataFrame) -> str:
    return "; ".join(
        f"{row.method}'s {row.measure} (partial ρ = {row.rho:.2f}, p_Holm = {max(row.p_holm, 0.001):.3f})"
        for row in table.itertuples()
    )


def predictor_markdown(table: pd.DataFrame) -> str:
    """The tests as a table: one row per method and measure, ρ for each predictor, the partial ρ."""
    if table.empty:
        return ""
    header = (
        ["method", "measure (sign)"] + [p.replace("_", " ") for p in PREDICTORS] + ["complexity, area fixed"]
    )
    lines = ["| " + " | ".join(header) + " |", "|" + "---|" * len(header)]
    for (method, measure), group in table.groupby(["method", "measure"], sort=False):
        plain = group[group["controlling_for"] == ""].set_index("predictor")
        partial = group[group["controlling_for"] == CONTROL].iloc[0]
        cells = [method, f"{measure} ({group['expected_sign'].iloc[0]})"]
        cells += [_rho_cell(plain.loc[p]) for p in PREDICTORS] + [_rho_cell(partial)]
        lines.append("| " + " | ".join(cells) + " |")
    return "\n".join(lines) + (
        "\n\nρ: Spearman over layouts (n layouts), one-sided p in the hypothesised direction, "
        "Holm-adjusted over every test of this suite; **bold**: holds at 0.05 after correction."
    )


def _rho_cell(test) -> str:
    if np.isnan(test["rho"]):
        return "—"
    p_holm = "<0.001" if test["p_holm"] < 0.001 else f"{test['p_holm']:.3f}"
    text = f"{test['rho']:+.2f} (p_Holm {p_holm}, n={test['n']})"
    return f"**{text}**" if test["p_holm"] < ALPHA else text
