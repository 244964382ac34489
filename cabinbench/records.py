"""The record format: one JSON object per episode, one file per run, trajectories beside it.

A run writes ``<out>/<layout>__<baseline>__<protocol>__k<K>__seed<S>-<UTC time>.jsonl``. Each
line is one finished episode with the fields of :data:`RECORD_FIELDS`, in that order, then every
metric of :mod:`cabinbench.metrics` (``METRICS``, plus ``TEAM_METRICS`` for K > 1):

- ``benchmark_version``: ``cabinbench.__version__``;
- ``git_commit``: ``git rev-parse HEAD`` of the source tree, or null when that fails;
- ``layout``, ``layout_hash`` (:attr:`Layout.content_hash`: the YAML text's SHA-256, 16 hex; for
  a generated layout its geometry's), ``layout_complexity`` (``{"normalized": ..., "total": ...}``,
  the study's §4.1, as measured when the episode ran; reports read the current measure through
  :func:`with_current_complexity`), ``suite`` (the suite the layout was played in,
  :mod:`cabinbench.suites`, or null);
- ``baseline`` (the name or ``package.module:Class`` given), ``baseline_config`` (its settings);
- ``protocol``, ``n_agents``;
- ``seed`` (the run's base seed) and ``episode`` (index in the run): the episode's own seed is
  ``seed + episode`` (see :mod:`cabinbench.episodes`);
- ``start``: the pose ``[x, y, heading]`` the episode started from (a team: one per robot);
- ``env_config`` (reward preset, ``max_steps`` and any other env setting);
- ``timestamp``: when the episode finished, ISO 8601 UTC.

Lines are appended, flushed and fsynced one by one, so an interrupted run keeps every finished
episode. The sibling ``.npz`` holds the map once, so that figures need nothing but the file:

- ``floor`` (rows, cols) bool: the layout's free floor on the coverage raster;
- ``origin`` (2,) float64 and ``resolution`` (): where pixel (0, 0) starts and its size (m);

and each episode's trajectory under ``episode<i>_<array>``:

- ``steps`` (n,) int32: the env steps sampled: every :data:`~cabinbench.metrics.CURVE_STRIDE`-th and the last;
- ``positions`` (n, K, 2) float32: robot centres (m) at those steps;
- ``coverage`` (n,) float32: coverage at those steps;
- ``pass_count`` (rows, cols) uint16: the final coverage raster (passes per pixel), from which
  the leaderboard's trajectory maps are drawn exactly (no replay of the footprints).

The ``.npz`` is compressed and rewritten after each episode to a temporary file that then
replaces it (``os.replace``), so it is never half-written. Readers: :func:`read_records` and
:func:`read_trajectories`.
"""

from __future__ import annotations

import datetime
import json
import os
import re
import subprocess
import warnings
import zipfile
from collections.abc import Iterable
from dataclasses import dataclass
from functools import lru_cache
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from cabinbench.errors import LayoutError
from cabinbench.layouts.complexity import layout_complexity
from cabinbench.layouts.fields import RESOLUTION
from cabinbench.layouts.model import Layout
from cabinbench.layouts.resolve import load_layout
from cabinbench.metrics import CURVE_STRIDE, METRICS, RATES, REACH_TIMES, TEAM_METRICS
from cabinbench.values import is_real_number, is_whole_number
from cabinbench.version import __version__

if TYPE_CHECKING:
    import pandas as pd

RECORD_FIELDS = (
    "benchmark_version",
    "git_commit",
    "layout",
    "layout_hash",
    "layout_complexity",
    "suite",
    "baseline",
    "baseline_config",
    "protocol",
    "n_agents",
    "seed",
    "episode",
    "start",
    "env_config",
    "timestamp",
)


@lru_cache(maxsize=1)
def git_commit() -> str | None:
    """The commit of the checkout this package runs from, or None (an installed copy, no git
    binary ...); never raises. A checkout is only trusted when the package is its ``cabinbench/``
    folder: an installed copy inside some other repository (a venv in a project) must not report
    that repository's commit."""
    package = Path(__file__).resolve().parent
    try:
        result = subprocess.run(
            ["git", "rev-parse", "--show-toplevel", "HEAD"],
            cwd=package,
            capture_output=True,
            text=True,
            timeout=10,
            check=False,
        )
    except (OSError, subprocess.SubprocessError):
        return None
    output = result.stdout.split()
    if result.returncode != 0 or len(output) != 2 or Path(output[0]).resolve() / "cabinbench" != package:
        return None
    return output[1] if re.fullmatch(r"[0-9a-f]{40}", output[1]) else None


def complexity_field(layout: Layout) -> dict:
    """A record's ``layout_complexity``."""
    complexity = layout_complexity(layout)
    return {"normalized": round(complexity.normalized, 6), "total": round(complexity.total, 6)}


def with_current_complexity(records: pd.DataFrame) -> pd.DataFrame:
    """``records`` with ``layout_complexity`` measured on each layout as it is now, so that a changed
    measure (complexity is a property of the layout, not of the episode) needs no episode run
    again. Only where the layout of that name loads and its ``layout_hash`` is the record's: a
    record of another version of the layout, or of one not on the search path, keeps its own."""
    if records.empty:
        return records
    current = {}
    for name, content_hash in records[["layout", "layout_hash"]].drop_duplicates().itertuples(index=False):
        try:
            layout = load_layout(name)
        except LayoutError:
            continue
        if layout.content_hash == content_hash:
            current[name, content_hash] = complexity_field(layout)
    records = records.copy()
    records["layout_complexity"] = [
        current.get((name, content_hash), recorded)
        for name, content_hash, recorded in zip(
            records["layout"], records["layout_hash"], records["layout_complexity"]
        )
    ]
    return records


def run_header(
    layout: Layout,
    baseline: str,
    baseline_config: dict,
    protocol: str,
    n_agents: int,
    seed: int,
    env_config: dict,
    suite: str | None = None,
) -> dict:
    """The fields shared by every record of a run (all of RECORD_FIELDS but ``episode``, ``start``
    and ``timestamp``)."""
    return {
        "benchmark_version": __version__,
        "git_commit": git_commit(),
        "layout": layout.name,
        "layout_hash": layout.content_hash,
        "layout_complexity": complexity_field(layout),
        "suite": suite,
        "baseline": baseline,
        "baseline_config": baseline_config,
        "protocol": protocol,
        "n_agents": n_agents,
        "seed": seed,
        "env_config": env_config,
    }


def safe_name(text) -> str:
    """``text`` fit for a file name (a baseline given as ``pkg.mod:Class`` has a colon)."""
    return re.sub(r"[^A-Za-z0-9_.-]+", "-", str(text))


def run_path(out_dir: str | os.PathLike, header: dict) -> Path:
    """A new records path ``<layout>__<baseline>__<protocol>__k<K>__seed<S>-<UTC time>[-<n>].jsonl``,
    created empty: the name is claimed at once (exclusive create), so runs of the same setting
    started in the same second, in parallel into one folder, each get a file of their own (``-1``,
    ``-2`` ...)."""
    now = datetime.datetime.now(datetime.timezone.utc)
    parts = [
        header["layout"],
        header["baseline"],
        header["protocol"],
        f"k{header['n_agents']}",
        f"seed{header['seed']}-{now:%Y%m%dT%H%M%SZ}",
    ]
    return _claim(Path(out_dir), "__".join(map(safe_name, parts)))


def _claim(out: Path, stem: str) -> Path:
    """``out/<stem>[-<n>].jsonl`` with the first free ``n``, created empty at once (exclusive create), so that
    no other process can take the same name; a name whose trajectory file exists is not free."""
    out.mkdir(parents=True, exist_ok=True)
    suffix = 0
    while True:
        path = out / (f"{stem}-{suffix}.jsonl" if suffix else f"{stem}.jsonl")
        suffix += 1
        if trajectory_path(path).exists():
            continue
        try:
            with open(path, "x", encoding="utf-8"):
                return path
        except FileExistsError:
            continue


def move_runs(folder: str | os.PathLike, out_dir: str | os.PathLike) -> list[Path]:
    """Move every records file in ``folder``, with its trajectory file, into ``out_dir`` under a name claimed
    there as :func:`run_path` claims one: runs played in folders of their own and started in the same second
    have the same name, and neither overwrites the other. Returns the new records paths."""
    moved = []
    for source in sorted(Path(folder).glob("*.jsonl")):
        target = _claim(Path(out_dir), source.stem)
        if trajectory_path(source).exists():
            os.replace(trajectory_path(source), trajectory_path(target))
        os.replace(source, target)  # last: a records file never stands without its trajectory
        moved.append(target)
    return moved


def trajectory_path(records_path: str | os.PathLike) -> Path:
    return Path(records_path).with_suffix(".npz")


def downsample(trajectory: dict) -> dict:
    """The stored form of :func:`~cabinbench.episodes.run_episode`'s trajectory (see module doc)."""
    last = len(trajectory["coverage"]) - 1
    steps = np.unique(np.append(np.arange(0, last + 1, CURVE_STRIDE), last)).astype(np.int32)
    return {
        "steps": steps,
        "positions": trajectory["positions"][steps].astype(np.float32),
        "coverage": trajectory["coverage"][steps].astype(np.float32),
        "pass_count": trajectory["pass_count"].astype(np.uint16),
    }


class RunWriter:
    """Writes one run: records appended line by line, trajectories kept in the sibling ``.npz``."""

    def __init__(self, path: str | os.PathLike, header: dict, layout: Layout):
        self.path, self.header = Path(path), header
        self.path.parent.mkdir(parents=True, exist_ok=True)
        self.trajectories: dict[str, np.ndarray] = {
            "floor": layout.free_raster,
            "origin": np.array(layout.origin),
            "resolution": np.array(RESOLUTION),
        }

    @property
    def trajectory_path(self) -> Path:
        return trajectory_path(self.path)

    def write(self, episode: int, metrics: dict, trajectory: dict) -> dict:
        """Save one finished episode (``metrics``: the env's record plus its ``start``); return its
        record. The trajectory goes first, so that every record line has its trajectory even if
        the run is killed in between."""
        for name, array in downsample(trajectory).items():
            self.trajectories[f"episode{episode}_{name}"] = array
        self._save_trajectories()
        timestamp = datetime.datetime.now(datetime.timezone.utc).isoformat(timespec="seconds")
        record = {**self.header, **metrics, "episode": episode, "timestamp": timestamp}
        record = {name: record[name] for name in RECORD_FIELDS} | {
            name: value for name, value in metrics.items() if name not in RECORD_FIELDS
        }
        with open(self.path, "a", encoding="utf-8") as file:
            file.write(json.dumps(record, default=_jsonable) + "\n")
            file.flush()
            os.fsync(file.fileno())
        return record

    def episodes_written(self) -> int:
        """Records on disk: the complete lines of the records file."""
        try:
            return self.path.read_bytes().count(b"\n")
        except FileNotFoundError:
            return 0

    def remove_if_empty(self) -> None:
        """Remove the run's files when no record reached disk (the name was claimed at the start)."""
        if not self.episodes_written():
            self.path.unlink(missing_ok=True)
            self.trajectory_path.unlink(missing_ok=True)

    def _save_trajectories(self) -> None:
        temporary = self.trajectory_path.with_name(self.trajectory_path.name + ".tmp")
        try:
            with open(temporary, "wb") as file:  # a file object: savez would append ".npz" to a name
                np.savez_compressed(file, **self.trajectories)
                file.flush()
                os.fsync(file.fileno())
            os.replace(temporary, self.trajectory_path)
        finally:  # interrupted (Ctrl-C) before the replace: no half-written file is left behind
            temporary.unlink(missing_ok=True)


def _jsonable(value):
    """numpy scalars and arrays inside records and configs."""
    if isinstance(value, np.generic):
        return value.item()
    if isinstance(value, np.ndarray):
        return value.tolist()
    return str(value)


def record_files(paths_or_dirs: str | os.PathLike | Iterable[str | os.PathLike]) -> list[Path]:
    """The ``.jsonl`` files named, or found (sorted) in the folders named."""
    if isinstance(paths_or_dirs, (str, os.PathLike)):
        paths_or_dirs = [paths_or_dirs]
    files = []
    for entry in map(Path, paths_or_dirs):
        files.extend(sorted(entry.glob("*.jsonl")) if entry.is_dir() else [entry])
    return files


class RecordWarning(UserWarning):
    """A record or a trajectory file that cannot be used; it is skipped, the others are read."""


LATER_FIELDS = ("suite", "start")  # fields of RECORD_FIELDS that records written before them lack


def metric_problem(name: str, value) -> str | None:
    """What is wrong with a record's value of metric ``name`` (:mod:`cabinbench.metrics`), or None."""
    if name in RATES:
        return None if isinstance(value, bool) else "not true or false"
    if name == "path_lengths":  # one per robot
        return None if isinstance(value, list) and all(map(_number, value)) else "not a list of numbers >= 0"
    if value is None and name in REACH_TIMES:  # never reached
        return None
    return None if _number(value) else "not a number >= 0"


def _number(value) -> bool:
    """A finite number >= 0, as every metric's values are."""
    return is_real_number(value) and value >= 0


def record_problem(record) -> str | None:
    """What makes a line's JSON value unusable as a record, or None: not an object, a field or metric
    missing, a metric's value of the wrong kind, text that is not Unicode (a lone surrogate: a name
    read from a file name in another encoding, which no report can write)."""
    if not isinstance(record, dict):
        return "not a JSON object"
    team = is_whole_number(record.get("n_agents")) and record["n_agents"] > 1
    for name in (*RECORD_FIELDS, *METRICS, *(TEAM_METRICS if team else ())):
        if name not in record and name not in LATER_FIELDS:
            return f"field {name!r} missing"
    for name in (*METRICS, *(TEAM_METRICS if team else ())):
        problem = metric_problem(name, record[name])
        if problem:
            return f"{name} {json.dumps(record[name])[:40]} is {problem}"
    try:
        json.dumps(record, ensure_ascii=False).encode("utf-8")
    except UnicodeEncodeError as error:
        text = error.object[error.start : error.end]
        return f"text that is not Unicode ({text!r}: a name from a file name in another encoding)"
    return None


def read_records(paths_or_dirs: str | os.PathLike | Iterable[str | os.PathLike]) -> pd.DataFrame:
    """Every usable record of the given files and folders as a DataFrame, one row per episode, in
    file order; the column ``source`` names the file. A line that is not a record
    (:func:`record_problem`), and a record whose trajectory its ``.npz`` lacks (or that does not
    open), is skipped with a :class:`RecordWarning` naming the file and the line; a truncated last
    line (a run killed mid-write) is skipped so too."""
    import pandas as pd  # here, not at the top: 0.4 s of the start-up of commands that only write records

    rows = []
    for path in record_files(paths_or_dirs):
        found = []
        for number, line, last in _lines(path):
            try:
                record = json.loads(line)
            except json.JSONDecodeError as error:
                if last:
                    _skip(f"{path}:{number}: skipping a truncated last line ({error})")
                    continue
                problem = f"not a JSON record ({error})"
            else:
                problem = record_problem(record)
            if problem:
                _skip(f"{path}:{number}: {problem}; skipping it")
            else:
                found.append((number, record))
        rows += [{**record, "source": str(path)} for record in _with_trajectories(path, found)]
    return pd.DataFrame(rows)


def _lines(path: Path) -> list[tuple[int, str, bool]]:
    """(number, text, whether it is an unterminated last line) of each line of a records file that
    holds something; a line that is not UTF-8 is left out with a warning."""
    data = path.read_bytes()
    lines = data.split(b"\n")
    numbered = []
    for number, line in enumerate(lines, start=1):
        try:
            text = line.decode("utf-8")
        except UnicodeDecodeError as error:
            _skip(f"{path}:{number}: not UTF-8 text ({error.reason}); skipping it")
            continue
        if text.strip():
            numbered.append((number, text, number == len(lines)))
    return numbered


def _with_trajectories(path: Path, found: list[tuple[int, dict]]) -> list[dict]:
    """The records of ``found`` whose trajectory the ``.npz`` beside ``path`` holds."""
    if not found:
        return []
    try:
        with np.load(trajectory_path(path)) as stored:
            keys = set(stored.files)
    except (OSError, ValueError, EOFError, zipfile.BadZipFile) as error:
        _skip(
            f"{trajectory_path(path)}: cannot read it ({error}); skipping the {len(found)} records of {path}"
        )
        return []
    kept = []
    for number, record in found:
        if f"episode{record['episode']}_pass_count" in keys:
            kept.append(record)
        else:
            where = trajectory_path(path).name
            _skip(f"{path}:{number}: episode {record['episode']} has no trajectory in {where}; skipping it")
    return kept


def _skip(message: str) -> None:
    warnings.warn(message, RecordWarning, stacklevel=3)


@dataclass
class StoredRun:
    """A run's ``.npz``: the map and each episode's trajectory (see the module doc)."""

    floor: np.ndarray
    origin: np.ndarray
    resolution: float
    episodes: dict[int, dict[str, np.ndarray]]  # episode index → steps, positions, coverage, pass_count

    @property
    def extent(self) -> tuple[float, float, float, float]:
        """(left, right, bottom, top) in metres, as matplotlib's ``imshow`` takes it."""
        rows, cols = self.floor.shape
        x0, y0 = self.origin
        return x0, x0 + cols * self.resolution, y0, y0 + rows * self.resolution


def read_trajectories(records_path: str | os.PathLike) -> StoredRun:
    """The ``.npz`` beside a records file."""
    episodes: dict[int, dict[str, np.ndarray]] = {}
    with np.load(trajectory_path(records_path)) as stored:
        for key in stored.files:
            if key.startswith("episode"):
                episode, name = key.removeprefix("episode").split("_", 1)
                episodes.setdefault(int(episode), {})[name] = stored[key]
        return StoredRun(stored["floor"], stored["origin"], float(stored["resolution"]), episodes)
