"""The random-motion gap of §5.2.3, tested (cabinbench.paper.random_motion): settings read back from
real records and layouts, and verdicts that follow from the numbers."""

import numpy as np
import pytest
import yaml

from cabinbench.commands import paper, run
from cabinbench.errors import UsageError
from cabinbench.paper.random_motion import (
    FACTORS,
    Setting,
    accounting_sentence,
    hypothesis_verdicts,
    read_settings,
    setting_verdict,
    write_layouts,
)

ALL = tuple(factor.name for factor in FACTORS)


def setting(changed: tuple[str, ...], coverage: list[float]) -> Setting:
    return Setting(changed, {}, np.array(coverage), np.full(len(coverage), 100.0), 0)


def spread(mean: float) -> list[float]:
    """Ten episodes around ``mean`` (sd about 0.03)."""
    return list(mean + np.linspace(-0.05, 0.05, 10))


def test_a_setting_is_placed_against_the_study_range_and_ours():
    ours = np.array(spread(0.45))
    assert setting_verdict(np.array(spread(0.60)), ours) == "in the study's range"
    assert setting_verdict(np.array(spread(0.80)), ours) == "above the study's range"
    assert setting_verdict(np.array(spread(0.50)), ours) == "raises ours, short of the study's range"
    assert setting_verdict(np.array(spread(0.30)), ours) == "lowers ours"
    assert setting_verdict(np.array(spread(0.46)), ours) == "does not change ours"


def test_hypotheses_are_judged_alone_and_needed_from_the_numbers():
    settings = [
        setting((), spread(0.45)),
        setting(("speed",), spread(0.80)),
        setting(("turn rate",), spread(0.50)),
        setting(("cell width",), spread(0.46)),
        setting(("budget",), spread(0.30)),
        setting(ALL, spread(0.60)),
        setting(("turn rate", "cell width", "budget"), spread(0.40)),  # all but speed
        setting(("speed", "cell width", "budget"), spread(0.58)),  # all but turn rate
    ]
    verdicts = {verdict.factor: verdict for verdict in hypothesis_verdicts(settings)}
    assert verdicts["speed"].verdict == "accounts for the difference"
    assert "needed: the other three without it give 40.0%" in verdicts["speed"].why
    assert verdicts["turn rate"].verdict == "accounts for part of it"
    assert "not needed: the other three without it give 58.0%" in verdicts["turn rate"].why
    assert verdicts["cell width"].verdict == "does not account for it"
    assert verdicts["budget"].verdict == "does not account for it"
    assert "lowers ours" in verdicts["budget"].why
    assert accounting_sentence(list(verdicts.values())) == (
        "Of the hypotheses tested one factor at a time, those that account for the difference on their "
        "own: speed; those that account for part of it: turn rate; those that do not account for it: "
        "cell width, budget."
    )
    # no factor alone reaches the range: the sentence says so
    short = [setting((), spread(0.45)), setting(("turn rate",), spread(0.50))]
    assert "on their own: none;" in accounting_sentence(hypothesis_verdicts(short))


@pytest.fixture(scope="module")
def recorded(tmp_path_factory):
    """A results folder with two real settings at the study's 60 s budget: ours, and the study's speed."""
    results = tmp_path_factory.mktemp("results")
    folder = results / "random_motion"
    layouts = write_layouts(folder / "layouts")
    speed = folder / "layouts" / "a320_cell_speed.yaml"
    assert speed in layouts and len(layouts) == 7  # every combination of speed, turn rate and width
    for layout in ("a320_cell", str(speed)):
        arguments = ["--baseline", "random_bounce_study", "--layout", layout, "--max-steps", "600"]
        assert run.main([*arguments, "--episodes", "2", "--out", str(folder)]) == 0
    return results


def test_settings_are_read_back_from_the_records_and_their_layouts(recorded):
    settings = read_settings(recorded / "random_motion")
    assert [s.changed for s in settings] == [("budget",), ("speed", "budget")]
    budget, speed = settings
    assert budget.values == {"speed": 0.5, "turn rate": 2.0, "cell width": 3.7, "budget": 60.0}
    assert speed.values["speed"] == FACTORS[0].study
    assert len(speed.coverage) == 2 and (speed.path_widths > budget.path_widths).all()

    assert paper.main(["--results", str(recorded), "--random-motion"]) == 0
    report = (recorded / "random_motion.md").read_text(encoding="utf-8")
    assert "| speed + budget | **4.23** | 2 | 3.7 | **60** |" in report
    assert "| the study (its values as read above) | 4.23 | 31.4159 | 3.15 | 60 | 55-65 % (n = 50)" in report


def test_a_changed_layout_or_a_foreign_value_is_a_user_error(recorded, tmp_path):
    speed = recorded / "random_motion" / "layouts" / "a320_cell_speed.yaml"
    text = speed.read_text(encoding="utf-8")
    try:
        speed.write_text(text.replace("4.23", "1.0"), encoding="utf-8")
        with pytest.raises(UsageError, match="a320_cell_speed.yaml: changed since the records"):
            read_settings(recorded / "random_motion")
    finally:
        speed.write_text(text, encoding="utf-8")
    # a layout of the folder at neither our speed nor the study's
    folder = tmp_path / "random_motion"
    (folder / "layouts").mkdir(parents=True)
    layout = yaml.safe_load(text)
    layout["robot"]["max_speed"] = 1.0
    (folder / "layouts" / "a320_cell_speed.yaml").write_text(yaml.safe_dump(layout), encoding="utf-8")
    arguments = [
        "--baseline",
        "random_bounce_study",
        "--layout",
        str(folder / "layouts" / "a320_cell_speed.yaml"),
    ]
    assert run.main([*arguments, "--max-steps", "600", "--episodes", "1", "--out", str(folder)]) == 0
    with pytest.raises(UsageError, match="speed 1 m/s is neither ours"):
        read_settings(folder)
    assert paper.main(["--results", str(tmp_path / "none"), "--random-motion"]) == 2
