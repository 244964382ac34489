"""The random-motion gap of §5.2.3, tested: why ``random_bounce_study`` covers less of ``a320_cell``
than the study's random robot ("mainly 55-65 %", Fig. 5.12(a)).

Four hypotheses, each a factor that moves from ours to the study's value (:data:`FACTORS`):

- *speed*: ours 0.5 m/s. The study prints none; its random robot drove 650-800 units in its 60 s
  (Fig. 5.12(c, e)). Read as robot widths - the study draws its robot 12 px wide in a 108 px cabin,
  9 robot cells across (§4.2.1), and its learned robot's 120-145 units covering 65-75 % of a cell
  rule out a smaller unit - that is 725 / 60 widths a second, 4.23 m/s for the 0.35 m robot: an
  average over turns and stops, so a lower bound on its top speed.
- *turn rate*: ours 2 rad/s (a turn on the spot takes up to 1.6 s, 16 steps). The study prints none;
  tested at its bound, any turn within one 0.1 s step (π / 0.1 s): if turning in no time does not
  close the gap, no turn rate does.
- *cell width*: the study prints no cell dimensions; its cabin map is 9 robot widths across (108 /
  12 px), ours 3.70 / 0.35 = 10.6: 3.15 m, every other dimension ours.
- *budget*: ours 3000 steps (the study's count) of 0.1 s = 300 s; the study's 3000 steps took
  about 60 s (Fig. 5.12(e)): 600 steps.

Not varied: the robot's size (0.35 m, the study's Create 2, §5.1; its simulated robot a box 12 px
wide) and the decision interval (the study's 60 s / 3000 steps = 0.02 s, Unity's fixed step; ours
0.1 s, ``TIME_STEP``, fixed in the simulation): with speed and budget in seconds the interval only
sets how soon a bump is noticed.

The experiment is every combination of the four (2⁴ settings), ``random_bounce_study`` in the
sequential protocol, 20 episodes a setting (``scripts/random_motion.sh``: seeds 0, 100, ..., 400,
4 episodes each). Speed, turn rate and width are layouts (``a320_cell`` with a ``robot`` block or
another width, written by :func:`write_layouts` into ``results/random_motion/layouts/``), the budget
is ``--max-steps``. Each setting's factor values are read back from the layouts and step limits its
records name, never from the script. Coverage is ``coverage_free`` when the episode ended (at the
budget, or earlier when the robot reached every goal marker, the study's end of an episode), as the
study measured it; intervals are Student-t intervals over the episodes.

Verdicts (:func:`setting_verdict`, :func:`hypothesis_verdicts`): a setting is *in* (or *above*) the
study's range when its mean is; else it *raises* or *lowers* ours when the Welch 95 % interval of its
difference from ours excludes 0, or *does not change* it. A hypothesis *accounts for the
difference* when its factor alone brings the mean into the range or above, *accounts for part* when
alone it raises ours short of the range, else *does not*; a factor is *needed* when all four reach
the range and the other three without it do not.
"""

from __future__ import annotations

import copy
import itertools
import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pandas as pd
import yaml

from cabinbench.errors import UsageError
from cabinbench.layouts.load import builtin_layout_dir
from cabinbench.layouts.model import Layout
from cabinbench.layouts.resolve import load_layout
from cabinbench.records import read_records
from cabinbench.sim.physics import TIME_STEP
from cabinbench.stats import Summary, t_interval

BASE_LAYOUT = "a320_cell"
BASELINE = "random_bounce_study"
FOLDER = Path("results/random_motion")  # the records; their layouts in its layouts/
STUDY_RANGE = (0.55, 0.65)  # Fig. 5.12(a): random motion covers "mainly 55-65 %"
STUDY_PATH = (650, 800)  # Fig. 5.12(c): its path, in the study's units (read as robot widths)
STUDY_COMPLETED = "0 of 50"  # §5.2.3: every random episode ran to the step limit
STUDY_STEPS = 3000  # §5.2.3: the study's step limit, ours too (scripts/make_results.sh)
ROBOT_DIAMETER = 0.35  # m, the study's Create 2 (§5.1) and our robot


@dataclass(frozen=True)
class Factor:
    """One hypothesis: a factor, its study value and where that comes from."""

    name: str
    hypothesis: str
    unit: str
    study: float
    source: str
    short: str  # in layout file names


FACTORS = (
    Factor(
        "speed",
        "the study's robot was faster",
        "m/s",
        round((sum(STUDY_PATH) / 2) / 60 * ROBOT_DIAMETER, 2),
        "not printed; its path, 650-800 units in 60 s (Fig. 5.12(c, e)), read as robot widths of 0.35 m",
        "speed",
    ),
    Factor(
        "turn rate",
        "the study's robot turned faster",
        "rad/s",
        round(math.pi / TIME_STEP, 4),
        "not printed; its bound: any turn within one step",
        "turn",
    ),
    Factor(
        "cell width",
        "the study's cell had another geometry",
        "m",
        round(9 * ROBOT_DIAMETER, 2),
        "its cabin map's 9 robot widths (108 / 12 px, §4.2.1); its cell's dimensions are not printed",
        "width",
    ),
    Factor(
        "budget",
        "the study's 60 s budget",
        "s",
        60.0,
        "3000 steps in about 60 s (Fig. 5.12(e))",
        "",
    ),
)
LAYOUT_FACTORS = FACTORS[:3]  # set in the layout; the budget is the run's --max-steps


def factor_values(layout: Layout, max_steps: int) -> dict[str, float]:
    """The four factors of a run: its robot's speed and turn rate, its cabin's width, its budget (s)."""
    return {
        "speed": layout.robot.max_speed,
        "turn rate": layout.robot.max_turn_rate,
        "cell width": layout.parameters["width"],
        "budget": max_steps * TIME_STEP,
    }


def our_values() -> dict[str, float]:
    """Ours: the built-in ``a320_cell`` at the study's 3000 steps."""
    return factor_values(load_layout(BASE_LAYOUT), STUDY_STEPS)


# ----------------------------------------------------------------------------- the settings' layouts
def write_layouts(folder: Path = FOLDER / "layouts") -> list[Path]:
    """``a320_cell`` with every non-empty combination of the layout factors at the study's value,
    as ``a320_cell_<speed|turn|width ...>.yaml`` in ``folder``."""
    base = yaml.safe_load((builtin_layout_dir() / f"{BASE_LAYOUT}.yaml").read_text(encoding="utf-8"))
    folder.mkdir(parents=True, exist_ok=True)
    written = []
    for count in range(1, len(LAYOUT_FACTORS) + 1):
        for changed in itertools.combinations(LAYOUT_FACTORS, count):
            layout = copy.deepcopy(base)
            names = [factor.name for factor in changed]
            layout["description"] = (
                f"{BASE_LAYOUT} with the study's {' and '.join(names)}: a setting of "
                "results/random_motion.md (written by cabinbench.paper.random_motion.write_layouts)."
            )
            robot = {}
            for factor in changed:
                if factor.name == "cell width":
                    layout["cabin"]["width"] = factor.study
                else:
                    robot["max_speed" if factor.name == "speed" else "max_turn_rate"] = factor.study
            if robot:
                layout["robot"] = robot
            path = folder / f"{BASE_LAYOUT}_{'_'.join(factor.short for factor in changed)}.yaml"
            path.write_text(yaml.safe_dump(layout, sort_keys=False), encoding="utf-8")
            written.append(path)
    return written


# ----------------------------------------------------------------------------- reading the records
@dataclass(frozen=True)
class Setting:
    """One setting's episodes: which factors are the study's, their values, its measurements."""

    changed: tuple[str, ...]  # factor names at the study's value, in FACTORS order
    values: dict[str, float]
    coverage: np.ndarray  # coverage_free per episode
    path_widths: np.ndarray  # path length per episode, in robot widths
    completed: int  # episodes that reached every goal marker (the study's end of an episode)

    @property
    def label(self) -> str:
        return " + ".join(self.changed) or "ours"

    @property
    def summary(self) -> Summary:
        return t_interval(self.coverage)


def changed_factors(values: dict[str, float], ours: dict[str, float], where: str) -> tuple[str, ...]:
    """The factors of ``values`` at the study's value; one at neither ours nor the study's is a user
    error naming ``where``."""
    changed = []
    for factor in FACTORS:
        value = values[factor.name]
        if math.isclose(value, factor.study, rel_tol=1e-6):
            changed.append(factor.name)
        elif not math.isclose(value, ours[factor.name], rel_tol=1e-6):
            raise UsageError(
                f"{where}: {factor.name} {value:g} {factor.unit} is neither ours ({ours[factor.name]:g}) nor "
                f"the study's ({factor.study:g}); rerun scripts/random_motion.sh"
            )
    return tuple(changed)


def setting_layout(folder: Path, name: str, layout_hash: str) -> Layout:
    """The layout a setting's records name: ``folder/layouts/<name>.yaml`` or a built-in one, as it
    was when they ran (the same content hash)."""
    path = folder / "layouts" / f"{name}.yaml"
    layout = load_layout(path if path.is_file() else name)
    if layout.content_hash != layout_hash:
        raise UsageError(
            f"{path if path.is_file() else name}: changed since the records of {folder} were written; "
            "rerun scripts/random_motion.sh"
        )
    return layout


def read_settings(folder: Path = FOLDER) -> list[Setting]:
    """Every setting recorded in ``folder`` (``random_bounce_study``, sequential, one robot), ours first,
    then by the number of factors changed."""
    records = read_records(folder) if folder.is_dir() else pd.DataFrame()
    if records.empty:
        return []
    records = records[(records["baseline"] == BASELINE) & (records["n_agents"] == 1)]
    records = records[records["protocol"] == "sequential"]
    records = records.assign(max_steps=[int(config["max_steps"]) for config in records["env_config"]])
    ours = our_values()
    settings = []
    for (name, layout_hash, max_steps), runs in records.groupby(["layout", "layout_hash", "max_steps"]):
        layout = setting_layout(folder, name, layout_hash)
        values = factor_values(layout, max_steps)
        settings.append(
            Setting(
                changed_factors(values, ours, f"{folder}: {name} at {max_steps} steps"),
                values,
                runs["coverage_free"].to_numpy(float),
                runs["path_length"].to_numpy(float) / layout.robot.tool_width,
                int(runs["goals_reached"].sum()),
            )
        )
    order = [factor.name for factor in FACTORS]
    return sorted(settings, key=lambda s: (len(s.changed), [order.index(name) for name in s.changed]))


# ----------------------------------------------------------------------------- verdicts
def difference_interval(sample: np.ndarray, ours: np.ndarray) -> tuple[float, float]:
    """The Welch 95 % interval of mean(sample) - mean(ours)."""
    from scipy import stats  # here, not at the top: 0.8 s of every command's start-up

    if len(sample) < 2 or len(ours) < 2:
        return math.nan, math.nan
    interval = stats.ttest_ind(sample, ours, equal_var=False).confidence_interval(0.95)
    return float(interval.low), float(interval.high)


def range_position(mean: float, study: tuple[float, float] = STUDY_RANGE) -> str:
    low, high = study
    return (
        "in the study's range"
        if low <= mean <= high
        else f"{'above' if mean > high else 'below'} the study's range"
    )


def setting_verdict(sample: np.ndarray, ours: np.ndarray, study: tuple[float, float] = STUDY_RANGE) -> str:
    """Where a setting's mean coverage stands: in or above the study's range, else whether it raises
    or lowers ours (the Welch interval of the difference excludes 0) or does not change it."""
    where = range_position(float(np.mean(sample)), study)
    if not where.startswith("below"):
        return where
    below, above = difference_interval(sample, ours)
    if below > 0:
        return "raises ours, short of the study's range"
    if above < 0:
        return "lowers ours"
    return "does not change ours"


ACCOUNTS = {  # a factor's setting alone -> what it says of the hypothesis
    "in the study's range": "accounts for the difference",
    "above the study's range": "accounts for the difference",
    "raises ours, short of the study's range": "accounts for part of it",
    "lowers ours": "does not account for it",
    "does not change ours": "does not account for it",
}


@dataclass(frozen=True)
class HypothesisVerdict:
    factor: str
    hypothesis: str
    verdict: str  # a value of ACCOUNTS
    why: str
    alone: Summary  # coverage with this factor alone at the study's value


def hypothesis_verdicts(
    settings: list[Setting], study: tuple[float, float] = STUDY_RANGE
) -> list[HypothesisVerdict]:
    """Per factor with a one-factor setting: whether it accounts for the gap alone (see the module doc),
    and whether all four need it."""
    by_changed = {setting.changed: setting for setting in settings}
    ours = by_changed.get(())
    if ours is None:
        return []
    every = by_changed.get(tuple(factor.name for factor in FACTORS))
    verdicts = []
    for factor in FACTORS:
        alone = by_changed.get((factor.name,))
        if alone is None:
            continue
        where = setting_verdict(alone.coverage, ours.coverage, study)
        why = (
            f"alone: {alone.summary.mean:.1%}, {where}, driving {np.mean(alone.path_widths):.0f} robot "
            f"widths an episode (the study's robot: {STUDY_PATH[0]}-{STUDY_PATH[1]})"
        )
        others = tuple(name for name in (f.name for f in FACTORS) if name != factor.name)
        without = by_changed.get(others)
        if every is not None and without is not None and every.coverage.mean() >= study[0]:
            needed = without.coverage.mean() < study[0]
            why += (
                f"; {'needed' if needed else 'not needed'}: the other three without it give "
                f"{without.summary.mean:.1%}"
            )
        verdicts.append(
            HypothesisVerdict(factor.name, factor.hypothesis, ACCOUNTS[where], why, alone.summary)
        )
    return verdicts


def gap_claims(settings: list[Setting]) -> list[tuple[str, str, str, str, str]]:
    """The reproduction report's rows of this test (claim, study, ours, verdict, why): each hypothesis
    alone, then all four together; none without records."""
    claims = [
        (
            f"random motion's gap: {verdict.hypothesis} (the study's {verdict.factor} alone, "
            "`results/random_motion.md`)",
            study_range(),
            interval_text(verdict.alone),
            verdict.verdict,
            verdict.why,
        )
        for verdict in hypothesis_verdicts(settings)
    ]
    ours = next((setting for setting in settings if not setting.changed), None)
    every = next((setting for setting in settings if len(setting.changed) == len(FACTORS)), None)
    if ours is not None and every is not None:
        claims.append(
            (
                "random motion's gap: all four factors at the study's values (`results/random_motion.md`)",
                f"{study_range()}, {STUDY_COMPLETED} reach every goal",
                f"{interval_text(every.summary)}, {every.completed} of {len(every.coverage)} "
                "reach every goal",
                setting_verdict(every.coverage, ours.coverage),
                f"drove {np.mean(every.path_widths):.0f} robot widths an episode (the study's: "
                f"{STUDY_PATH[0]}-{STUDY_PATH[1]})",
            )
        )
    return claims


def accounting_sentence(verdicts: list[HypothesisVerdict]) -> str:
    """Which hypotheses account for the gap alone, which in part, which not ("none" where none)."""
    parts = []
    for verdict, label in (
        ("accounts for the difference", "account for the difference on their own"),
        ("accounts for part of it", "account for part of it"),
        ("does not account for it", "do not account for it"),
    ):
        factors = [v.factor for v in verdicts if v.verdict == verdict]
        parts.append(f"{label}: {', '.join(factors) or 'none'}")
    return "Of the hypotheses tested one factor at a time, those that " + "; those that ".join(parts) + "."


# ----------------------------------------------------------------------------- the report
def study_range() -> str:
    return f"{STUDY_RANGE[0] * 100:.0f}-{STUDY_RANGE[1] * 100:.0f} %"


def interval_text(summary: Summary) -> str:
    return f"{summary.mean:.1%} [{summary.low:.1%}, {summary.high:.1%}] (n = {summary.n})"


def setting_row(setting: Setting, ours: Setting | None) -> str:
    values = []
    for factor in FACTORS:
        text = f"{setting.values[factor.name]:g}"
        values.append(f"**{text}**" if factor.name in setting.changed else text)
    if ours is None or setting is ours:
        verdict = range_position(setting.summary.mean)
    else:
        verdict = setting_verdict(setting.coverage, ours.coverage)
    return (
        f"| {setting.label} | {' | '.join(values)} | {interval_text(setting.summary)} | "
        f"{np.mean(setting.path_widths):.0f} | {setting.completed} of {len(setting.coverage)} | {verdict} |"
    )


def random_motion_table(settings: list[Setting]) -> str:
    """The settings' table, with the study's row first."""
    ours = next((setting for setting in settings if not setting.changed), None)
    header = " | ".join(f"{factor.name} ({factor.unit})" for factor in FACTORS)
    study = " | ".join(f"{factor.study:g}" for factor in FACTORS)
    lines = [
        f"| setting | {header} | coverage, mean [95 % t interval] (n) | path (robot widths) "
        "| reached every goal | against the study's range |",
        "|---|" + "---|" * (len(FACTORS) + 4),
        f"| the study (its values as read above) | {study} | {study_range()} (n = 50) | "
        f"{STUDY_PATH[0]}-{STUDY_PATH[1]} | {STUDY_COMPLETED} | — |",
    ]
    return "\n".join(lines + [setting_row(setting, ours) for setting in settings])


def within_budget_sentence(settings: list[Setting]) -> str:
    """Every setting with the study's 60 s budget against ours: the study's figures hold together only
    within its budget (its path is its speed over its 60 s)."""
    ours = next((s for s in settings if not s.changed), None)
    within = [s for s in settings if "budget" in s.changed]
    if ours is None or not within:
        return ""
    parts = [
        f"{s.label}: {s.summary.mean:.1%}, {setting_verdict(s.coverage, ours.coverage)} "
        f"({np.mean(s.path_widths):.0f} robot widths)"
        for s in within
    ]
    return f"Within the study's {FACTORS[-1].study:g} s budget: " + "; ".join(parts) + "."


def random_motion_markdown(settings: list[Setting]) -> str:
    """``results/random_motion.md``: the experiment, its table and the verdicts, all from ``settings``."""
    verdicts = hypothesis_verdicts(settings)
    together = gap_claims(settings)[len(verdicts) :]
    sources = "\n".join(
        f"- {factor.name}: {factor.hypothesis}; the study's value {factor.study:g} {factor.unit}: "
        f"{factor.source}."
        for factor in FACTORS
    )
    findings = "\n".join(f"- {v.factor} ({v.hypothesis}): **{v.verdict}**: {v.why}." for v in verdicts)
    parts = [
        "# Random motion's gap, tested (§5.2.3)",
        f"`{BASELINE}` on `{BASE_LAYOUT}` (sequential protocol) covers less of the free floor "
        f"than the study's random robot (mainly {study_range()}, Fig. 5.12(a)). Each hypothesis "
        "moves one factor from ours to the study's value; every combination of them was run. "
        "Values in bold are the study's. Coverage is the covered part of the free floor when the "
        "episode ended (at the budget, or when the robot reached every goal marker, the study's "
        "end of an episode); intervals are Student-t intervals over episodes. Made by "
        "`scripts/random_motion.sh`; the rules are in `cabinbench/paper/random_motion.py`. Not "
        "varied: the robot's size (0.35 m, the study's Create 2) and the decision interval (the "
        f"study's 0.02 s, ours {TIME_STEP:g} s, fixed in the simulation).",
        sources,
        random_motion_table(settings),
        "## Verdicts",
        findings or "(no one-factor settings recorded)",
        accounting_sentence(verdicts),
        within_budget_sentence(settings),
        *(f"All four together: {ours}, {verdict}; it {why}." for _, _, ours, verdict, why in together),
    ]
    return "\n\n".join(part for part in parts if part) + "\n"


def write_report(results: Path) -> Path:
    """Write ``<results>/random_motion.md`` from the records in ``<results>/random_motion/``."""
    folder = results / FOLDER.name
    settings = read_settings(folder)
    if not settings:
        raise UsageError(f"--results: no {BASELINE} records in {folder}; run `bash scripts/random_motion.sh`")
    out = results / f"{FOLDER.name}.md"
    out.write_text(random_motion_markdown(settings), encoding="utf-8")
    return out


def random_motion_finding(results: Path) -> str:
    """The paper's sentences on the gap: which hypotheses account for it, and what the study's budget
    allows; from the records in ``<results>/random_motion/``."""
    settings = read_settings(results / FOLDER.name)
    if not settings:
        return f"(no {BASELINE} records in `{results / FOLDER.name}`: run `bash scripts/random_motion.sh`)"
    return f"{accounting_sentence(hypothesis_verdicts(settings))} {within_budget_sentence(settings)}"
