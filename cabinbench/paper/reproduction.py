"""The paper's reproduction report: one row per claim of the study, checked against the benchmark.

Each row gives where the study makes the claim, the study's value, ours, and a verdict with its
reason. The study's values are quoted from the dissertation (they are the claims); ours are
measured now, from the built-in layouts, the ``paper`` reward preset, the shipped policies'
training configurations (``results/training/<learner>/config.json``; the study's pair ships its two
networks' configurations and training summaries beside their checkpoints) and the recorded episodes
(``results/runs``, sequential protocol, one robot), never typed. Verdicts follow fixed rules:

- a value: *reproduced* when ours equals the study's to its printed precision, *partly* when it is
  within 5 % of it, else *not*;
- a range ("mainly 55-65 %"): *reproduced* when our mean lies in it, *partly* within 0.10 of it;
- a ratio ("more than 5 times"): *reproduced* when ours reaches the study's, *partly* when it at
  least points the same way (above 1);
- a completion claim: from the fraction of our episodes that reached every goal marker (the study's
  white cubes, its end of a mission; *reproduced* above one half, *partly* when any did).

A learned policy's claims (§5.2.3, §5.2.4) are judged on each training seed, then over all of them
(:mod:`cabinbench.paper.seeds`: every seed shown, the verdict of all, how many seeds stand behind it).
Only fixed-start episodes outside any suite count, as the study ran them. §5.2.3's random-motion gap
is tested factor by factor in ``results/random_motion.md`` (:mod:`cabinbench.paper.random_motion`).

Intervals over episodes are 95 % percentile-bootstrap intervals, over training seeds Student-t
intervals (:mod:`cabinbench.stats`).
"""

from __future__ import annotations

import json
from collections.abc import Callable
from pathlib import Path

import pandas as pd

from cabinbench.envs.coverage_env import CoverageEnv
from cabinbench.layouts.complexity import layout_complexity
from cabinbench.layouts.load import builtin_layout_dir
from cabinbench.layouts.resolve import load_layout
from cabinbench.leaderboard.headline import CHECKPOINTS  # the study's pair keeps its records beside them
from cabinbench.paper.random_motion import gap_claims, read_settings
from cabinbench.paper.seeds import (
    STUDY_STAGES,
    completed_of,
    coverage_of,
    interval,
    learner_records,
    learner_seeds,
    over_seeds,
)
from cabinbench.records import read_trajectories
from cabinbench.sim.events import RobotEvents, StepEvents
from cabinbench.sim.physics import TIME_STEP
from cabinbench.sim.rewards import paper

RANDOM = ("random_bounce", "random_bounce_study")
STUDY_RANDOM_SECONDS = 60.0  # Fig. 5.12(e): the random robot's 3000 steps took "around 60s"
LEARNERS = ("ppo_gail_study", "ppo_gail")  # the study's configuration, then our tuned variant
COLUMNS = "| where | claim | study | ours | verdict |\n|---|---|---|---|---|"


# ----------------------------------------------------------------------------- verdicts
def value_verdict(ours: float, study: float, precision: float) -> str:
    if abs(ours - study) <= precision / 2:
        return "reproduced"
    return "partly" if abs(ours - study) <= 0.05 * abs(study) else "not"


def range_verdict(ours: float, low: float, high: float) -> str:
    if low <= ours <= high:
        return "reproduced"
    return "partly" if low - 0.10 <= ours <= high + 0.10 else "not"


def ratio_verdict(ours: float, at_least: float) -> str:
    if ours >= at_least:
        return "reproduced"
    return "partly" if ours > 1 else "not"


def completion_verdict(success_rate: float) -> str:
    return "reproduced" if success_rate > 0.5 else "partly" if success_rate > 0 else "not"


def variant(learner: str) -> str:
    """Whose method a learner is: the study's, or our tuned variant of it."""
    return (
        "the study's configuration"
        if learner == "ppo_gail_study"
        else "by our tuned variant, not the study's method"
    )


def row(where: str, claim: str, study: str, ours: str, verdict: str, why: str = "") -> str:
    return f"| {where} | {claim} | {study} | {ours} | **{verdict}**{': ' + why if why else ''} |"


# ----------------------------------------------------------------------------- inputs
def coverage_free_at(runs: pd.DataFrame, seconds: float) -> list[float]:
    """Each episode's ``coverage_free`` after ``seconds`` of simulated time, from its stored
    trajectory (``coverage`` of the coverable area, scaled to the free floor)."""
    layout = load_layout(runs["layout"].iloc[0])
    scale = layout.coverable_area / layout.free_area
    values = []
    for source, episode in zip(runs["source"], runs["episode"]):
        stored = read_trajectories(source).episodes[int(episode)]
        reached = stored["steps"] <= round(seconds / TIME_STEP)
        values.append(float(stored["coverage"][reached][-1]) * scale)
    return values


def episodes(records: pd.DataFrame, layout: str, baseline: str) -> pd.DataFrame:
    """The sequential single-robot episodes of ``baseline`` on ``layout`` from the layout's own start,
    outside any suite (empty when none)."""
    if records.empty:
        return records
    chosen = (
        (records["layout"] == layout)
        & (records["baseline"] == baseline)
        & (records["protocol"] == "sequential")
        & (records["n_agents"] == 1)
        & (records["suite"].isna() if "suite" in records else True)
    )
    return records[chosen]


def training_config(results: Path, learner: str, study_checkpoints: Path = CHECKPOINTS) -> dict | None:
    """The learner's training configuration, with ``trained``: (steps, layouts) per network. For
    ``ppo_gail_study`` the cleaning network's, and the steps each network reached of those planned
    (its ``.training.json`` in ``study_checkpoints``). None without the files (see ``training_record``)."""
    if learner == "ppo_gail_study":
        stages = [study_checkpoints / f"{learner}_{stage}" for stage in STUDY_STAGES]
        files = [(stage.with_suffix(".config.json"), stage.with_suffix(".training.json")) for stage in stages]
        if not all(path.is_file() for pair in files for path in pair):
            return None
        configs = [[json.loads(path.read_text(encoding="utf-8")) for path in pair] for pair in files]
        trained = [(summary["timesteps"], config["layouts"]) for config, summary in configs]
        return {**configs[0][0], "trained": trained}
    path = results / "training" / learner / "config.json"
    if not path.is_file():
        return None
    config = json.loads(path.read_text(encoding="utf-8"))
    steps = config.get("num_envs", 0) * config.get("num_steps_per_env", 0) * config.get("iterations", 0)
    return {**config, "trained": [(steps, config.get("layouts", []))]}


def training_record(learner: str) -> str:
    """Where the learner's training record is read from, as the report names it."""
    if learner == "ppo_gail_study":
        return "`baselines/ppo_gail/checkpoints/` (`ppo_gail_study_<stage>.config.json`, `.training.json`)"
    return f"`results/training/{learner}/`"


def limit(runs: pd.DataFrame) -> str:
    """The step limit the episodes ran under."""
    limits = sorted({int(config["max_steps"]) for config in runs["env_config"]})
    return "/".join(map(str, limits)) + " steps"


# ----------------------------------------------------------------------------- sections
def complexity_rows() -> list[str]:
    rows = []
    for name, table, study in (
        ("paper_matrix_a", "Table 4.1", 4.4859),
        ("paper_matrix_b", "Table 4.1", 11.1065),
    ):
        total = layout_complexity(load_layout(name)).total
        rows.append(
            row(
                table,
                f"complexity of {name.split('_')[-1].upper()} (`{name}`)",
                f"{study}",
                f"{total:.4f}",
                value_verdict(total, study, 1e-4),
            )
        )
    cabin = layout_complexity(load_layout("paper_cabin_map"))
    why = (
        "the study does not print its 59 × 9 cells; `paper_cabin_map` is the nearest of the maps its "
        "description allows (`tests/test_complexity.py` searches them), see its description"
    )
    rows.append(
        row(
            "Table 4.2",
            "cabin map, total",
            "257.8176",
            f"{cabin.total:.4f}",
            value_verdict(cabin.total, 257.8176, 1e-4),
            why,
        )
    )
    rows.append(
        row(
            "Table 4.2",
            "cabin map, normalised (59 × 9)",
            "0.4855",
            f"{cabin.normalized:.4f}",
            value_verdict(cabin.normalized, 0.4855, 1e-4),
            why,
        )
    )
    layouts = [load_layout(path) for path in sorted(builtin_layout_dir().glob("*.yaml"))]
    cabins = {
        layout.name: layout_complexity(layout).normalized for layout in layouts if layout.kind == "cabin"
    }
    low, high = min(cabins.values()), max(cabins.values())
    rows.append(
        row(
            "§4.2.1, Table 5.1",
            "cabins are more complex than offices (real maps ≤ 0.3)",
            "0.4855 vs ≤ 0.3",
            f"cabin layouts {low:.4f}-{high:.4f}",
            "reproduced" if low > 0.3 else "not",
            "the three office maps of Table 5.1 are not public, so only the study's bound is compared",
        )
    )
    return rows


def reward_rows(configs: dict[str, dict | None]) -> list[str]:
    step = paper(StepEvents([RobotEvents()]), 0, 1, 0.5)

    def term(**events) -> float:
        return paper(StepEvents([RobotEvents(**events)]), 0, 1, 0.5) - step

    cleared = paper(StepEvents([RobotEvents(goals_reached=1, collisions=1)], cells_cleared=1), 0, 1, 0.5)
    terms = [
        ("Table 4.4", "new goal (white cube) reached", 0.5, term(goals_reached=1)),
        ("Tables 4.4/4.5", "obstacle hit", -0.3, term(collisions=1)),
        ("Tables 4.4/4.5", "bound reached", -10.0, term(bound_violations=1)),
        ("Tables 4.4/4.5", "every step", -0.01, step),
        ("Table 4.5", "exit landmark reached", 2.0, term(exits_reached=1)),
    ]
    rows = [
        row(where, f"`paper` reward: {claim}", f"{study:+g}", f"{ours:+g}", value_verdict(ours, study, 1e-9))
        for where, claim, study, ours in terms
    ]
    rows.append(
        row(
            "Table 4.4",
            "`paper` reward: cell cleared",
            "set 3",
            f"set {cleared:g} (other terms dropped)",
            "reproduced" if cleared == 3.0 else "not",
        )
    )
    ends = ", ".join(
        f"`{learner}` trains with it {'on' if config.get('terminate_on_bound') else 'off'}"
        for learner, config in configs.items()
        if config
    )
    rows.append(
        row(
            "Table 4.5",
            "a bound ends the episode",
            "yes (training)",
            f"env option `terminate_on_bound`; {ends}",
            "reproduced" if all(c.get("terminate_on_bound") for c in configs.values() if c) else "partly",
            "evaluation episodes go on against the solid bound, so coverage is measured over the whole limit",
        )
    )
    return rows


def learner_rows(configs: dict[str, dict | None], results: Path) -> list[str]:
    """Table 4.3 (what the policy observes) and Tables 5.2/5.3 (how it was trained), per learner."""
    rows = []
    for learner, config in configs.items():
        if config is None:
            rows.append(
                row(
                    "Tables 4.3, 5.2, 5.3",
                    f"`{learner}`",
                    "—",
                    f"no training record in {training_record(learner)}",
                    "not",
                    "not trained: see `results/differences.md`",
                )
            )
            continue
        parts = CoverageEnv("a320_cell", coverage_patch=config.get("coverage_patch", 0)).observation_layout
        seen = " + ".join(f"{name} ({part.stop - part.start})" for name, part in parts.items())
        rows.append(
            row(
                "Table 4.3",
                f"`{learner}` observes",
                "rays (distance, tag) + velocity",
                seen,
                "reproduced" if set(parts) <= {"lidar", "velocity"} else "partly",
                ""
                if set(parts) <= {"lidar", "velocity"}
                else "it also sees a coverage patch the study avoided",
            )
        )
        algorithm = config.get("algorithm", {})
        trained = " + ".join(
            f"{steps / 1e6:.1f}M on {' + '.join(layouts)}" for steps, layouts in config["trained"]
        )
        hidden = config.get("hidden_dims", [])
        settings = [
            ("hidden layers", "512 × 2", " × ".join(map(str, hidden)) or "?", hidden == [512, 512]),
            (
                "training steps",
                "6M cleaning + 2M tracking",
                trained,
                sum(steps for steps, _ in config["trained"]) >= 8e6,
            ),
            ("reward", "Tables 4.4/4.5", f"`{config.get('reward')}`", config.get("reward") == "paper"),
            (
                "GAIL strength",
                "0.3",
                str(algorithm.get("gail_strength", "default")),
                algorithm.get("gail_strength") == 0.3,
            ),
        ]
        for name, study, ours, same in settings:
            rows.append(
                row("Tables 5.2/5.3", f"`{learner}` {name}", study, ours, "reproduced" if same else "not")
            )
    differences = results / "differences.md"
    if differences.is_file():
        rows.append(
            row(
                "Tables 5.2/5.3",
                "every other setting",
                "Tables 5.2/5.3",
                "`results/differences.md`",
                "see there",
                "one row per difference, with its reason",
            )
        )
    return rows


def headline_rows(records: pd.DataFrame, learned: pd.DataFrame, results: Path, seeds: dict) -> list[str]:
    """§5.2.3 on the cleaning cell: random motion, its gap tested factor by factor, and every training
    seed of the learned policies (``learned``, with its ``seed`` column; ``seeds``: each learner's seeds)."""
    rows = []
    for baseline in RANDOM:
        runs = episodes(records, "a320_cell", baseline)
        if not runs.empty:
            rows += random_motion_rows(baseline, runs)
    rows += random_motion_gap_rows(results)
    random = episodes(records, "a320_cell", RANDOM[-1])
    for learner, expected in seeds.items():
        runs = episodes(learned, "a320_cell", learner)
        if not runs.empty:
            rows += learner_cell_rows(learner, runs, random, expected)
    return rows


def random_motion_rows(baseline: str, runs: pd.DataFrame) -> list[str]:
    """§5.2.3, Fig. 5.12(a, e): what random motion covers (in its limit, and in the study's 60 s),
    and that it never completes the cell."""
    early = coverage_free_at(runs, STUDY_RANDOM_SECONDS)
    return [
        row(
            "§5.2.3, Fig. 5.12(a)",
            f"random motion covers (`{baseline}`, {limit(runs)})",
            "55-65 %",
            interval(runs["coverage_free"]),
            range_verdict(runs["coverage_free"].mean(), 0.55, 0.65),
            "covered part of all free floor, as the study measured it",
        ),
        row(
            "§5.2.3, Fig. 5.12(e)",
            f"random motion covers in the study's {STUDY_RANDOM_SECONDS:.0f} s (`{baseline}`)",
            "55-65 %",
            interval(early),
            range_verdict(sum(early) / len(early), 0.55, 0.65),
            "the study's 3000 steps took about 60 s; ours are 0.1 s each",
        ),
        row(
            "§5.2.3",
            f"random motion never completes (`{baseline}`)",
            "0 of 50 in 3000 steps",
            f"{int(runs['goals_reached'].sum())} of {len(runs)} in {limit(runs)}",
            "reproduced" if runs["goals_reached"].sum() == 0 else "not",
            "completed: every goal marker (the study's white cubes) reached",
        ),
    ]


def random_motion_gap_rows(results: Path) -> list[str]:
    """§5.2.3: why random motion covers less here, each hypothesis tested (``results/random_motion.md``);
    none without its records."""
    return [row("§5.2.3", *claim) for claim in gap_claims(read_settings(results / "random_motion"))]


def learner_cell_rows(
    learner: str, runs: pd.DataFrame, random: pd.DataFrame, expected: list[str]
) -> list[str]:
    """§5.2.3, Fig. 5.12(b-f), per training seed: what a learned policy covers, whether it completes
    the cell, and how much longer random motion (``random``'s episodes; none: no ratios) drives and takes."""
    claims = [
        (
            "§5.2.3, Fig. 5.12(b)",
            f"RL covers (`{learner}`)",
            "65-75 %",
            coverage_of,
            lambda m: range_verdict(m, 0.65, 0.75),
        ),
        (
            "§5.2.3",
            f"RL completes the cell (`{learner}`)",
            "yes (Fig. 5.12(f))",
            completed_of,
            completion_verdict,
        ),
    ]
    rows = []
    for where, claim, study, measure, verdict_of in claims:
        ours, verdict, why = over_seeds(runs, measure, verdict_of, expected)
        rows.append(row(where, claim, study, ours, verdict, f"{why}; {variant(learner)}"))
    if random.empty:
        return rows
    for metric, claim, study, at_least in (
        ("path_length", "path", "> 5×", 5.0),
        ("time", "time", "≈ 3×", 2.5),
    ):

        def ratio(episodes: pd.DataFrame, metric: str = metric) -> tuple[float, str]:
            value = random[metric].mean() / episodes[metric].mean()
            return value, f"{value:.2f}× (RL {interval(episodes[metric], '.1f')})"

        ours, verdict, why = over_seeds(
            runs, ratio, lambda value, at_least=at_least: ratio_verdict(value, at_least), expected, ".2f"
        )
        rows.append(
            row(
                "§5.2.3, Fig. 5.12(c-f)",
                f"random / RL {claim} (`{RANDOM[-1]}` / `{learner}`)",
                study,
                f"random {interval(random[metric], '.1f')}; {ours}",
                verdict,
                f"{why}; random over {limit(random)}, RL over {limit(runs)} (it stops when the cell is "
                "clean)",
            )
        )
    return rows


def transfer_rows(learned: pd.DataFrame, seeds: dict[str, list[str]]) -> list[str]:
    """§5.2.4, per training seed: the policy trained on the cleaning cell, tested zero-shot elsewhere."""
    claims = (
        ("shape_changed", "§5.2.4, Fig. 5.13", "shape-changed cells", (0.60, 0.70), "mostly completes"),
        ("b777_3col", "§5.2.4, Fig. 5.14", "three columns of seats", (0.55, 0.65), "mostly completes"),
        ("full_cabin", "§5.2.4, Fig. 5.15", "the whole cabin, 10 cells", None, "cleans cell by cell"),
    )
    rows = []
    for learner, expected in seeds.items():
        for layout, where, what, coverage, completes in claims:
            runs = episodes(learned, layout, learner)
            judged = [(f"`{learner}` {completes}: {what}", "yes", completed_of, completion_verdict)]
            if coverage:
                low, high = coverage
                in_range = lambda mean, low=low, high=high: range_verdict(mean, low, high)  # noqa: E731
                judged.insert(
                    0, (f"`{learner}` covers {what}", f"{low:.0%}-{high:.0%}", coverage_of, in_range)
                )
            for claim, study, measure, verdict_of in judged if not runs.empty else ():
                ours, verdict, why = over_seeds(runs, measure, verdict_of, expected)
                rows.append(row(where, claim, study, ours, verdict, f"{why}; {variant(learner)}"))
    return rows


def reproduction_table(records: pd.DataFrame, results: Path, study_checkpoints: Path = CHECKPOINTS) -> str:
    """The reproduction report's table (see the module doc); the study's pair's training records are
    read from ``study_checkpoints``, further training seeds' episodes from ``results/ablation_runs``."""
    configs = {learner: training_config(results, learner, study_checkpoints) for learner in LEARNERS}
    seeds = learner_seeds(results, configs)
    learned = learner_records(records, results, seeds)
    recorded = set(learned["baseline"]) if not learned.empty else set()
    seeds = {learner: expected for learner, expected in seeds.items() if learner in recorded}
    sections: list[Callable[[], list[str]]] = [
        complexity_rows,
        lambda: reward_rows(configs),
        lambda: learner_rows(configs, results),
        lambda: headline_rows(records, learned, results, seeds),
        lambda: transfer_rows(learned, seeds),
    ]
    return "\n".join([COLUMNS, *(line for section in sections for line in section())])
