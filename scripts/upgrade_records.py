"""Add the headline metrics to records written before they existed, from what each record kept.

    python scripts/upgrade_records.py [FOLDER ...]     (default: results/runs results/ablation_runs)

Before ``goals_reached``, ``time_limit``, ``clean_time`` and ``clean_score`` were recorded,
``success`` meant "the protocol's end was reached" (every goal marker in ``sequential``). A
record lacking them gets, exactly as the episode would record them now
(:class:`cabinbench.metrics.EpisodeTracker`):

- ``goals_reached``: its old ``success``;
- ``time_limit``: its ``env_config.max_steps`` (or the layout's) times the step;
- ``clean_time``: the first sample of its stored coverage curve (the ``.npz`` beside it, every
  :data:`~cabinbench.metrics.CURVE_STRIDE` steps and the last) at or above the layout's
  ``success_coverage`` — the samples the tracker reads;
- ``success``: ``clean_time`` is not None; ``clean_score``: :func:`cabinbench.metrics.clean_score`.

Every other field is kept as it was. Files are rewritten atomically; a record that already has the
fields is left alone, so running it twice changes nothing.
"""

from __future__ import annotations

import json
import os
import sys
from functools import cache
from pathlib import Path

import numpy as np

from cabinbench.layouts.resolve import load_layout
from cabinbench.metrics import clean_score
from cabinbench.sim.physics import TIME_STEP

DEFAULT_FOLDERS = ("results/runs", "results/ablation_runs")
NEW_FIELDS = ("goals_reached", "time_limit", "clean_time", "success", "clean_score")


@cache
def layout_limits(name: str) -> tuple[int, float]:
    layout = load_layout(name)
    return layout.max_steps, layout.success_coverage


def upgraded(record: dict, curve: np.ndarray, curve_steps: np.ndarray) -> dict:
    """``record`` with the new fields, placed where a new record has them (after ``cells_cleared``)."""
    max_steps, level = layout_limits(record["layout"])
    max_steps = (record.get("env_config") or {}).get("max_steps") or max_steps
    time_limit = max_steps * TIME_STEP
    cleaned = np.flatnonzero(curve >= np.float32(level))
    clean_time = float(curve_steps[cleaned[0]] * TIME_STEP) if len(cleaned) else None
    new = {
        "goals_reached": bool(record["success"]),
        "time_limit": time_limit,
        "clean_time": clean_time,
        "success": clean_time is not None,
        "clean_score": clean_score(record["coverage"], clean_time, time_limit, level),
    }
    result = {}
    for key, value in record.items():
        if key == "success":
            continue
        result[key] = value
        if key == "cells_cleared":
            result.update(new)
    return result


def upgrade_file(path: Path) -> int:
    """Upgrade the records of one ``.jsonl`` file; return how many changed."""
    lines = path.read_text(encoding="utf-8").splitlines()
    records = [json.loads(line) for line in lines]
    if all("goals_reached" in record for record in records):
        return 0
    with np.load(path.with_suffix(".npz")) as trajectories:
        out = [
            record
            if "goals_reached" in record
            else upgraded(
                record,
                trajectories[f"episode{record['episode']}_coverage"],
                trajectories[f"episode{record['episode']}_steps"],
            )
            for record in records
        ]
    temporary = path.with_name(path.name + ".tmp")
    temporary.write_text("".join(json.dumps(record) + "\n" for record in out), encoding="utf-8")
    os.replace(temporary, path)
    return sum("goals_reached" not in record for record in records)


def main(folders: list[str]) -> int:
    for folder in folders or DEFAULT_FOLDERS:
        files = sorted(Path(folder).glob("*.jsonl"))
        changed = sum(upgrade_file(path) for path in files)
        print(f"{folder}: {changed} records upgraded in {len(files)} files")
    return 0


if __name__ == "__main__":
    raise SystemExit(main(sys.argv[1:]))
