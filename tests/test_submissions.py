"""Submissions: a plugin baseline's result is written as one file, filed, shown and verified by replay;
every malformed or dishonest file is refused in one line, and a tampered record fails verification."""

import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from cabinbench.commands import leaderboard, run
from cabinbench.layouts.suites import get_suite
from cabinbench.leaderboard import submissions
from cabinbench.leaderboard.submissions import SubmissionError, checksum

from .plugin import install_spinner

ROOT = Path(__file__).resolve().parents[1]
CLASSIC = get_suite("classic")
STEPS = "8"  # short episodes, for the benchmark's own records beside the submission
PER_LAYOUT = 2


@pytest.fixture(scope="module")
def plugin(tmp_path_factory):
    """(folder, the plugin package's folder, a submission of the plugin baseline on the classic suite)."""
    root = tmp_path_factory.mktemp("submission")
    site = install_spinner(root / "site")
    with pytest.MonkeyPatch.context() as patch:
        patch.syspath_prepend(str(site))
        submission = root / "spinner.json"
        arguments = ["--baseline", "spinner", "--suite", "classic", "--episodes-per-layout", str(PER_LAYOUT)]
        out = ["--out", str(root / "runs"), "--submission", str(submission)]  # the protocol's step limits
        assert run.main([*arguments, *out]) == 0
        yield root, site, submission


@pytest.fixture
def own_runs(tmp_path):
    """A tiny folder of the benchmark's own records, for the tables the submission joins."""
    arguments = ["--baseline", "random_bounce", "--layout", "a320_cell", "--episodes", "2"]
    assert run.main([*arguments, "--max-steps", STEPS, "--out", str(tmp_path / "runs")]) == 0
    return tmp_path / "runs"


def test_a_submission_holds_everything_needed_to_check_and_replay_it(plugin):
    _, _, submission = plugin
    body = json.loads(submission.read_text())
    assert body["checksum"] == checksum(body)
    assert body["suite"] == {
        "name": "classic",
        "version": CLASSIC.version,
        "layout_hashes": CLASSIC.content_hashes(),
    }
    assert body["baseline"]["entry_point"] == "spinner_pkg:Spinner"
    assert body["packages"]["spinner-pkg"] == "0.1" and body["packages"]["cabinbench"]
    seeds = sorted((record["layout"], record["seed"] + record["episode"]) for record in body["records"])
    protocol = [
        (layout, position * PER_LAYOUT + episode)
        for position, layout in enumerate(CLASSIC.layout_names)
        for episode in range(PER_LAYOUT)
    ]
    assert seeds == sorted(protocol)


def test_a_plugin_submission_is_filed_shown_and_verified(plugin, own_runs, tmp_path, monkeypatch):
    _, site, submission = plugin
    monkeypatch.syspath_prepend(str(site))
    monkeypatch.chdir(ROOT)  # the site cites the repository's CITATION.cff
    folder, out = tmp_path / "submissions", tmp_path / "results"
    common = ["--runs", str(own_runs), "--submissions", str(folder), "--out", str(out)]
    assert leaderboard.main([*common, "--add", str(submission)]) == 0
    [filed] = folder.glob("*.json")
    assert filed.read_bytes() == submission.read_bytes()
    assert leaderboard.main(common) == 0
    assert "| spinner (submission, unverified) |" in (out / "leaderboard.md").read_text()

    every = len(json.loads(filed.read_text())["records"])
    assert leaderboard.main([*common, "--verify", str(filed), "--episodes", "3"]) == 0
    assert submissions.status(filed, json.loads(filed.read_text())) == f"unverified (3 of {every} replayed)"
    assert leaderboard.main([*common, "--verify", str(filed)]) == 0  # every episode, by default
    assert (
        submissions.status(filed, json.loads(filed.read_text())) == f"verified ({every} of {every} replayed)"
    )
    assert leaderboard.main([*common, "--site", str(tmp_path / "site")]) == 0
    index = (tmp_path / "site" / "index.html").read_text()
    assert index.count(f"submission, verified ({every} of {every} replayed)") == len(CLASSIC.layout_names)
    page = (tmp_path / "site" / "baselines" / "spinner.html").read_text()
    assert "Turns on the spot." in page and "spinner_pkg:Spinner" in page


def test_verification_catches_a_tampered_record(plugin, tmp_path, capsys, monkeypatch):
    """A changed number with a recomputed checksum passes the file checks; the replay finds it."""
    root, site, submission = plugin
    monkeypatch.syspath_prepend(str(site))
    body = json.loads(submission.read_text())
    body["records"][7]["coverage"] += 0.25
    body["checksum"] = checksum(body)
    tampered = tmp_path / "tampered.json"
    tampered.write_text(json.dumps(body))
    folder = tmp_path / "submissions"
    filed = submissions.add(tampered, folder)
    verify = ["--runs", str(root / "runs"), "--submissions", str(folder), "--verify", str(filed)]
    # a partial replay that misses the changed record matches, and still does not verify the file
    assert leaderboard.main([*verify, "--episodes", "3", "--seed", str(seed_missing(body, 7, 3))]) == 0
    assert "not verified" in capsys.readouterr().out
    assert submissions.status(filed, body) == f"unverified (3 of {len(body['records'])} replayed)"
    assert leaderboard.main(verify) == 1  # every episode: the changed one among them
    record = body["records"][7]
    assert (
        f"{record['layout']} seed {record['seed'] + record['episode']}: coverage submitted"
        in capsys.readouterr().out
    )
    assert submissions.status(filed, body) == "unverified (replay differs)"


def seed_missing(body: dict, index: int, episodes: int) -> int:
    """A seed of --verify's choice of ``episodes`` episodes that leaves out record ``index``."""
    size = len(body["records"])
    return next(
        seed
        for seed in range(100)
        if index not in np.random.default_rng(seed).choice(size, size=episodes, replace=False)
    )


def rewrite(body: dict, change) -> dict:
    body = json.loads(json.dumps(body))
    change(body)
    body["checksum"] = checksum(body)
    return body


def set_in(path: list, value):
    def change(body):
        target = body
        for key in path[:-1]:
            target = target[key]
        target[path[-1]] = value

    return change


def drop_layout(layout):
    def change(body):
        body["records"] = [record for record in body["records"] if record["layout"] != layout]

    return change


def drop_field(name):
    return lambda body: body["records"][0].pop(name)


REJECTIONS = {
    "suite not an object": (set_in(["suite"], "classic"), "field 'suite' is \"classic\", not an object"),
    "baseline without its config": (
        lambda body: body["baseline"].pop("config"),
        "field 'baseline.config' missing",
    ),
    "team size not a number": (
        set_in(["n_agents"], "two"),
        "field 'n_agents' is \"two\", not a whole number",
    ),
    "team size 0": (set_in(["n_agents"], 0), "field 'n_agents' is 0, not a whole number >= 1"),
    "entry point not a string": (
        set_in(["baseline", "entry_point"], 5),
        "field 'baseline.entry_point' is 5, not a string or null",
    ),
    "unknown suite": (set_in(["suite", "name"], "nope"), "unknown suite"),
    "other suite version": (set_in(["suite", "version"], 0), "made for suite classic version 0"),
    "suite hash": (
        set_in(["suite", "layout_hashes", "a320_cell"], "0" * 16),
        "layout a320_cell has hash 0000",
    ),
    "record hash": (set_in(["records", 0, "layout_hash"], "f" * 16), "record 0: layout a320_cell hash ffff"),
    "missing layout": (drop_layout("full_cabin"), "layout full_cabin of suite classic has no episodes"),
    "foreign layout": (set_in(["records", 0, "layout"], "cabin-v1-test/0000"), "not in suite classic"),
    "other suite's record": (
        set_in(["records", 0, "suite"], "cabin-v1-test"),
        "record 0: suite 'cabin-v1-test'",
    ),
    "partial": (lambda body: body["records"].pop(0), "missing [0]"),
    "duplicate episode": (
        set_in(["records", 1, "episode"], 0),
        "episode seed(s) [0] recorded more than once",
    ),
    "seeds off protocol": (set_in(["records", 0, "seed"], 100), "not in the protocol [100]"),
    "seeds of another layout": (
        set_in(["records", 2, "seed"], 0),
        "a320_tracking_cell: the protocol's episode",
    ),
    "missing field": (drop_field("coverage"), "record 0: field 'coverage' missing"),
    "bad number": (set_in(["records", 0, "coverage"], 1.5), "record 0: coverage 1.5 is outside [0, 1]"),
    "not a number": (set_in(["records", 0, "time"], "soon"), "record 0: time 'soon' is not a number"),
    "success not a truth value": (
        set_in(["records", 0, "success"], "yes"),
        "record 0: success 'yes' is not true",
    ),
    "reach time negative": (set_in(["records", 0, "t90"], -1.0), "record 0: t90 -1.0 is not a number >= 0"),
    "layout not a string": (set_in(["records", 0, "layout"], [1]), "record 0: layout [1] is not a string"),
    "mixed entry": (
        set_in(["records", 2, "baseline"], "random_bounce"),
        "record 2: baseline 'random_bounce'",
    ),
    "no records": (set_in(["records"], []), "no records"),
    "longer step limit": (
        set_in(["records", 0, "env_config", "max_steps"], 99999),
        "record 0: a320_cell ran with max_steps 99999, the suite's protocol gives it 1500",
    ),
    "random start on classic": (
        set_in(["records", 0, "env_config", "random_start"], True),
        "record 0: a320_cell ran from another start than the suite's protocol (the layout's start)",
    ),
}


@pytest.mark.parametrize("kind", REJECTIONS)
def test_each_kind_of_bad_submission_is_refused_in_one_line(plugin, tmp_path, kind):
    _, _, submission = plugin
    change, message = REJECTIONS[kind]
    bad = tmp_path / "bad.json"
    bad.write_text(json.dumps(rewrite(json.loads(submission.read_text()), change)))
    with pytest.raises(SubmissionError, match=None) as refused:
        submissions.add(bad, tmp_path / "submissions")
    assert message in str(refused.value) and "\n" not in str(refused.value)
    assert not (tmp_path / "submissions").exists()  # nothing filed


def test_a_changed_file_a_foreign_file_and_a_second_copy_are_refused(plugin, tmp_path):
    _, _, submission = plugin
    folder = tmp_path / "submissions"
    edited = tmp_path / "edited.json"
    edited.write_text(submission.read_text().replace('"coverage": 0.', '"coverage": 0.9', 1))
    for path, message in (
        (edited, "checksum does not match the content"),
        (ROOT / "CITATION.cff", "not a JSON file"),
        (ROOT / "pyproject.toml", "not a JSON file"),
    ):
        with pytest.raises(SubmissionError, match=message):
            submissions.add(path, folder)
    submissions.add(submission, folder)
    with pytest.raises(SubmissionError, match="this submission is already filed"):
        submissions.add(submission, folder)


def test_the_commands_refuse_with_one_line_and_exit_status_2(plugin, tmp_path):
    """As a user meets them: a bad file for --add, and --verify of a baseline not installed here."""
    _, _, submission = plugin
    bad = tmp_path / "bad.json"
    bad.write_text(json.dumps(rewrite(json.loads(submission.read_text()), drop_layout("b777_3col"))))
    for action, path, message in (
        ("--add", bad, "layout b777_3col of suite classic has no episodes"),
        (
            "--verify",
            submission,
            "baseline 'spinner' is not installed here; install the package that provides",
        ),
    ):
        completed = subprocess.run(
            [sys.executable, "-m", "cabinbench.leaderboard", "--runs", str(tmp_path), action, str(path)],
            capture_output=True,
            text=True,
            timeout=120,
            cwd=tmp_path,
        )
        assert completed.returncode == 2, completed.stderr
        assert completed.stderr.count("\n") == 1 and message in completed.stderr, completed.stderr
