"""The paper's abstract, its headline findings and its compute table, written from the headline
rows (:mod:`cabinbench.leaderboard.headline`) so that every number in them is generated.

Each sentence states what the numbers show and nothing stronger: a difference is called one only
when the two intervals do not overlap; otherwise the sentence says the intervals overlap.
"""

from __future__ import annotations

import math

from cabinbench.leaderboard.curves import CURVES_CAPTION
from cabinbench.leaderboard.headline import HEADLINE_SUITES, TrainingCost
from cabinbench.stats import Summary

PLANNERS = ("boustrophedon",)  # methods that are given the map and their pose
RANDOM = ("random_bounce", "random_bounce_study")


def score_text(summary: Summary | None, unit: str) -> str:
    """``0.774 [0.741, 0.802] (n = 100 layouts)``."""
    if summary is None:
        return "not measured"
    if math.isnan(summary.low):
        return f"{summary.mean:.3f} (n = {summary.n} {unit})"
    return f"{summary.mean:.3f} [{summary.low:.3f}, {summary.high:.3f}] (n = {summary.n} {unit})"


def _unit(row: dict, suite: str) -> str:
    return "seeds" if row[f"{suite} seeds"] > 1 else "layouts"


def _name(row: dict) -> str:
    return f"`{row['baseline']}`" + (f" (K = {row['n_agents']})" if row["n_agents"] > 1 else "")


def separated(a: Summary, b: Summary) -> bool:
    """The two intervals do not overlap (both must have one)."""
    if any(math.isnan(bound) for bound in (a.low, a.high, b.low, b.high)):
        return False
    return a.low > b.high or b.low > a.high


def _scored(rows: list[dict], suite: str) -> list[dict]:
    return sorted((row for row in rows if row[suite] is not None), key=lambda row: -row[suite].mean)


def findings(rows: list[dict]) -> list[str]:
    """The headline findings, one sentence each, from the rows."""
    test, ood = HEADLINE_SUITES
    ranked = _scored([row for row in rows if row["n_agents"] == 1], test)
    if not ranked:
        return ["No method has records on the test suite yet."]
    best, sentences = ranked[0], []
    sentences.append(
        f"On `{test}` the best single robot is {_name(best)} with a headline score of "
        f"{score_text(best[test], _unit(best, test))}; it cleans the floor in "
        f"{best['success'].mean:.0%} of the test episodes."
    )
    learned = [row for row in ranked if row["baseline"] not in (*PLANNERS, *RANDOM)]
    if learned:
        top = learned[0]
        cleaned = max(row["success"].mean for row in learned if row["success"] is not None)
        verb = "lies below" if separated(top[test], best[test]) else "overlaps"
        sentences.append(
            f"The best learned single robot, {_name(top)}, scores {score_text(top[test], _unit(top, test))}, "
            f"whose interval {verb} that of {_name(best)}; "
            + (
                "no learned policy cleans the floor in any test episode, so their scores rank coverage alone."
                if cleaned == 0
                else f"the learned policies clean the floor in at most {cleaned:.0%} of test episodes."
            )
        )
    study = next((row for row in ranked if row["baseline"] == "ppo_gail_study"), None)
    walk = next((row for row in ranked if row["baseline"] == "random_bounce"), None)
    if study and walk:
        relation = "below" if study[test].mean < walk[test].mean else "above"
        strength = "" if separated(study[test], walk[test]) else ", though the intervals overlap"
        sentences.append(
            f"The study's configuration as we run it, `ppo_gail_study`, scores "
            f"{score_text(study[test], _unit(study, test))}, {relation} random motion's "
            f"{score_text(walk[test], _unit(walk, test))}{strength}."
        )
    ood_ranked = _scored([row for row in rows if row["n_agents"] == 1], ood)
    if ood_ranked:
        drops = [
            f"{_name(row)} {row[test].mean:.3f} → {row[ood].mean:.3f}"
            for row in ood_ranked
            if row[test] is not None
        ]
        sentences.append(f"Out of distribution (`{ood}`) the scores move as " + "; ".join(drops) + ".")
    return sentences


def _row(rows: list[dict], baseline: str) -> dict | None:
    return next((row for row in rows if row["baseline"] == baseline), None)


def relation(a: Summary, b: Summary) -> str:
    """Where interval ``a`` stands to ``b``: "below", "above", or "overlaps"."""
    if not separated(a, b):
        return "overlaps"
    return "below" if a.mean < b.mean else "above"


def relation_text(a: dict, b: dict, suite: str) -> str:
    """``a``'s interval on ``suite`` against ``b``'s, in words."""
    where = relation(a[suite], b[suite])
    if where == "overlaps":
        return f"the intervals of {_name(a)} and {_name(b)} overlap"
    return f"{_name(a)}'s interval lies {where} that of {_name(b)}"


MEMORY_VERDICTS = {
    "below": "memory, as trained here, does not recover what the patch gives",
    "above": "memory, as trained here, does better than the patch",
    "overlaps": "these runs cannot tell memory from the patch",
}


def memory_sentence(ranked: list[dict]) -> str | None:
    """Does memory recover what the coverage patch gives? ``ppo_lstm`` against ``ppo``, the same PPO seeing
    the patch (single-robot rows on the test suite; None until both are scored)."""
    test = HEADLINE_SUITES[0]
    memory, patch = _row(ranked, "ppo_lstm"), _row(ranked, "ppo")
    if memory is None or patch is None:
        return None
    return (
        f"Memory instead of a map: `ppo_lstm` (PPO with an LSTM on lidar and velocity, no coverage patch) "
        f"scores {score_text(memory[test], _unit(memory, test))} against "
        f"{score_text(patch[test], _unit(patch, test))} for `ppo` (the same PPO seeing the patch); "
        f"{relation_text(memory, patch, test)}, so {MEMORY_VERDICTS[relation(memory[test], patch[test])]}."
    )


def imitation_sentence(ranked: list[dict]) -> str | None:
    """Learning from the planner: ``bc`` and ``dagger`` against their teacher, the boustrophedon planner
    (single-robot rows on the test suite; None until one of them is scored)."""
    test = HEADLINE_SUITES[0]
    teacher = _row(ranked, "boustrophedon")
    students = [row for row in (_row(ranked, "bc"), _row(ranked, "dagger")) if row is not None]
    if teacher is None or not students:
        return None
    scores = " and ".join(f"{_name(row)} {score_text(row[test], _unit(row, test))}" for row in students)
    relations = "; ".join(relation_text(row, teacher, test) for row in students)
    return (
        f"Learning from the planner: {scores}, against {score_text(teacher[test], _unit(teacher, test))} "
        f"for their teacher {_name(teacher)}; {relations}."
    )


def learner_findings(rows: list[dict]) -> list[str]:
    """The findings on the learners a reviewer asks for first, one sentence each: learning from the planner,
    and memory instead of the coverage patch (in the findings list, not the abstract)."""
    ranked = _scored([row for row in rows if row["n_agents"] == 1], HEADLINE_SUITES[0])
    return [sentence for sentence in (imitation_sentence(ranked), memory_sentence(ranked)) if sentence]


def abstract(rows: list[dict], complexity_finding: str) -> str:
    """The abstract: what the benchmark is, then the findings and the complexity finding."""
    methods = len({(row["baseline"], row["n_agents"]) for row in rows})
    return " ".join(
        [
            "cabinbench is an open benchmark for complete coverage path planning by cleaning robots in "
            "environments full of repeated obstacles, airline cabins first, built from a PhD study that "
            "trained PPO with curiosity and GAIL to clean a cabin cell by cell.",
            f"We score {methods} methods (planners, random motion, learned policies, teams) on generated "
            "cabins held out from training and on cabins outside the training distribution, with a "
            "headline score that counts cleaning the floor first and speed second, so that stopping "
            "early with floor left dirty never pays.",
            *findings(rows),
            complexity_finding,
        ]
    )


def compute_table(rows: list[dict]) -> str:
    """Per learned method: env steps and wall-clock of its training, per run and over its runs."""
    lines = [
        "| method | training runs | env steps per run | wall-clock per run (h) | wall-clock, all runs (h) |",
        "|---|---:|---:|---:|---:|",
    ]
    seen = set()
    for row in sorted(rows, key=lambda row: row["baseline"]):
        cost: TrainingCost | None = row["cost"]
        if cost is None or row["baseline"] in seen:
            continue
        seen.add(row["baseline"])
        lines.append(
            f"| `{row['baseline']}` | {cost.runs} | {cost.env_steps / 1e6:.2f} M | "
            f"{cost.wall_clock_s / 3600:.2f} | {cost.all_runs_wall_clock_s / 3600:.2f} |"
        )
    return "\n".join(lines)


FIGURE_CAPTIONS = {
    "trajectory": "The first episode of `{1}` on `{0}` ({2} protocol, K = {3}): the floor it covered "
    "(shaded) and the path of each robot.",
    "coverage_time": "Coverage of `{0}` over simulated time, one line per method: the median over episodes "
    "and the interquartile band.",
    "bars_coverage": "Coverage of `{0}` per method and protocol: the mean and its 95% bootstrap interval.",
    "bars_time": "Episode time on `{0}` per method and protocol: the mean and its 95% bootstrap interval.",
    "suite": "`{0}`: {1}.",
    "training": "Training curves of `{0}` (the shipped seed): per-iteration metrics and, where recorded, "
    "the validation episodes.",
    "makespan_agents": "Team makespan against the number of robots K, per layout (dashed: the ideal T(1)/K).",
    "ablation_coverage": "Coverage of each ablation on the four cabin layouts, every training seed.",
    "learning_curves": CURVES_CAPTION,
}
SUITE_FIGURES = {
    "profiles": "performance profiles, the share of layouts above each level",
    "improvement": "probability of improvement P(X > Y) on coverage, every ordered pair of methods",
    "complexity": "coverage and T90 against normalised complexity and against coverable area, one point "
    "per layout",
}


def figure_caption(stem: str) -> str:
    """The caption of a leaderboard figure, from its file name (``kind__part__part...``)."""
    kind, *parts = stem.split("__")
    if kind == "trajectory" and len(parts) == 4:
        parts[3] = parts[3].removeprefix("k")
    if kind == "suite" and len(parts) == 2:
        parts = [parts[0], SUITE_FIGURES.get(parts[1], parts[1])]
    template = FIGURE_CAPTIONS.get(kind)
    if template is None or template.count("{") > len(parts):
        return f"`{stem}`."
    return template.format(*parts)
