"""The paper's findings on the learners a reviewer asks for first (``paper.summary.learner_findings``): each
sentence follows from the intervals, says "overlap" where they do, and is absent until its rows are scored."""

from __future__ import annotations

import pytest

from cabinbench.leaderboard.headline import HEADLINE_SUITES
from cabinbench.paper.summary import learner_findings
from cabinbench.stats import Summary

TEST = HEADLINE_SUITES[0]


def row(baseline: str, mean: float, low: float, high: float, seeds: int = 5, agents: int = 1) -> dict:
    return {
        "baseline": baseline,
        "n_agents": agents,
        TEST: Summary(mean, low, high, seeds if seeds > 1 else 100),
        f"{TEST} seeds": seeds,
    }


@pytest.mark.parametrize(
    "memory, verdict",
    [
        (
            (0.10, 0.05, 0.15),
            "`ppo_lstm`'s interval lies below that of `ppo`, so memory, as trained here, does not",
        ),
        (
            (0.50, 0.45, 0.55),
            "`ppo_lstm`'s interval lies above that of `ppo`, so memory, as trained here, does better",
        ),
        ((0.29, 0.20, 0.31), "the intervals of `ppo_lstm` and `ppo` overlap, so these runs cannot tell"),
    ],
)
def test_the_memory_finding_follows_from_the_intervals(memory, verdict):
    rows = [row("ppo", 0.30, 0.25, 0.35), row("ppo_lstm", *memory), row("boustrophedon", 0.8, 0.79, 0.81, 1)]
    sentence = next(text for text in learner_findings(rows) if text.startswith("Memory instead of a map"))
    assert verdict in sentence
    assert f"{memory[0]:.3f} [{memory[1]:.3f}, {memory[2]:.3f}] (n = 5 seeds)" in sentence


def test_learning_from_the_planner_names_each_student_against_its_teacher_and_a_team_row_is_not_read():
    rows = [
        row("boustrophedon", 0.80, 0.79, 0.81, seeds=1),
        row("bc", 0.40, 0.10, 0.85),  # overlaps the teacher
        row("dagger", 0.02, 0.01, 0.03, seeds=1),
        row("ppo_lstm", 0.9, 0.85, 0.95, agents=4),  # a team: not the memory learner's single-robot row
    ]
    (sentence,) = learner_findings(rows)
    assert sentence.startswith(
        "Learning from the planner: `bc` 0.400 [0.100, 0.850] (n = 5 seeds) and `dagger`"
    )
    assert "(n = 100 layouts) for their teacher `boustrophedon`" in sentence
    assert "the intervals of `bc` and `boustrophedon` overlap" in sentence
    assert "`dagger`'s interval lies below that of `boustrophedon`" in sentence


def test_no_learner_finding_before_its_rows_are_scored():
    assert learner_findings([row("boustrophedon", 0.8, 0.79, 0.81, 1), row("ppo", 0.3, 0.25, 0.35)]) == []
