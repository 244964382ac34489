"""Records written before the headline metrics existed are upgraded to exactly what the episode
records now: the upgrade of a record stripped back to its old form gives the record back."""

import json
import subprocess
import sys
from pathlib import Path

from cabinbench.commands import run

ROOT = Path(__file__).resolve().parents[1]


def test_an_old_record_upgrades_to_what_the_episode_records_now(tmp_path):
    for baseline in (
        "boustrophedon",
        "random_bounce",
    ):  # the planner cleans the cell, the random walk does not
        arguments = [
            "--baseline",
            baseline,
            "--layout",
            "a320_cell",
            "--episodes",
            "2",
            "--max-steps",
            "1200",
        ]
        assert run.main([*arguments, "--out", str(tmp_path)]) == 0
    files = sorted(tmp_path.glob("*.jsonl"))
    now = {path: path.read_text(encoding="utf-8") for path in files}
    for path in files:  # back to the old form: no new fields, success meaning "goals reached"
        old = []
        for line in now[path].splitlines():
            record = json.loads(line)
            record["success"] = record.pop("goals_reached")
            for field in ("time_limit", "clean_time", "clean_score"):
                del record[field]
            old.append(json.dumps(record))
        path.write_text("\n".join(old) + "\n", encoding="utf-8")
    command = [sys.executable, str(ROOT / "scripts" / "upgrade_records.py"), str(tmp_path)]
    for _ in range(2):  # a second pass changes nothing
        subprocess.run(command, check=True, capture_output=True, cwd=ROOT)
        assert {path: path.read_text(encoding="utf-8") for path in files} == now
    cleaned = [json.loads(line)["success"] for text in now.values() for line in text.splitlines()]
    assert True in cleaned and False in cleaned  # both branches of the upgrade were exercised
