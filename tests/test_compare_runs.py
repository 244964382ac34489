"""scripts/compare_runs.py, by which a training setting is adopted or not, reads each run's chosen checkpoint
on cabin-v1-val and places a group against the reference's seed spread; runs it cannot compare fairly get
one line and exit status 2."""

import json
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
LAYOUTS = ("cabin-v1-val/0001", "cabin-v1-val/0002")


def make_run(folder: Path, seed: int, scores: dict[int, float], layouts=LAYOUTS, clean_score=True) -> Path:
    """A finished run whose checkpoint at each iteration scores the given mean clean_score on both layouts
    (one layout 0.1 above the mean, the other 0.1 below)."""
    folder.mkdir(parents=True)
    (folder / "config.json").write_text(json.dumps({"seed": seed}))
    last = max(scores)
    (folder / "metrics.csv").write_text(f"iteration,train_time\n{last},{last * 1.5}\n")
    rows = [
        "iteration,layout,coverage,success,clean_score"
        if clean_score
        else "iteration,layout,coverage,success"
    ]
    for iteration, score in scores.items():
        for layout, offset in zip(layouts, (0.1, -0.1)):
            rows.append(f"{iteration},{layout},0.5,0.0" + (f",{score + offset}" if clean_score else ""))
    (folder / "validation.csv").write_text("\n".join(rows) + "\n")
    return folder


def compare(*groups: list) -> subprocess.CompletedProcess:
    command = [sys.executable, str(ROOT / "scripts" / "compare_runs.py")]
    for name, *runs in groups:
        command += ["--group", name, *map(str, runs)]
    return subprocess.run(command, capture_output=True, text=True, cwd=ROOT)


def test_each_seed_is_read_at_its_chosen_checkpoint_and_a_group_placed_against_the_reference_spread(tmp_path):
    reference = [
        make_run(tmp_path / f"a{seed}", seed, {200: 0.3, 400: 0.4 + 0.1 * seed}) for seed in range(3)
    ]
    below = [make_run(tmp_path / f"b{seed}", seed, {200: 0.35, 400: 0.2}) for seed in range(2)]
    within = [make_run(tmp_path / "c0", 0, {200: 0.45, 400: 0.1})]
    done = compare(["defaults", *reference], ["cheaper", *below], ["other", *within])
    assert done.returncode == 0, done.stderr
    table = done.stdout.splitlines()
    assert "| defaults | 2 | 400 | 0.600 | 0.600 | 10.0 | 1.50 |" in table
    assert "| cheaper | 0 | 200 | 0.350 | 0.200 | 10.0 | 1.50 |" in table  # the best, not the last
    verdicts = [line for line in table if line.startswith("- ")]
    assert verdicts[0].startswith("- defaults: chosen checkpoints' val clean_score 0.500 [")
    assert "(t interval, n = 3 seeds)" in verdicts[0]
    assert verdicts[1].endswith("its mean lies below defaults's seed spread [0.400, 0.600]")
    assert verdicts[2] == (
        "- other: chosen checkpoints' val clean_score 0.450 (one seed: no interval); 10.0 min of training "
        "a run; its mean lies within defaults's seed spread [0.400, 0.600]"
    )


def test_runs_that_cannot_be_compared_fairly_get_one_line_and_exit_2(tmp_path):
    reference = [make_run(tmp_path / "a", 0, {200: 0.3})]
    cases = {
        "validated on different layouts": [make_run(tmp_path / "b", 0, {200: 0.3}, layouts=("x", "y"))],
        "no clean_score": [make_run(tmp_path / "c", 0, {200: 0.3}, clean_score=False)],
        "no config.json": [tmp_path / "missing"],
    }
    for expected, runs in cases.items():
        done = compare(["defaults", *reference], ["other", *runs])
        assert done.returncode == 2 and expected in done.stderr, (expected, done.stderr)
        assert len(done.stderr.strip().splitlines()) == 1 and not done.stdout
