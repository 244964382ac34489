"""Submissions: a result sent in by someone else, checked, filed and verified by replaying it.

A submission is one self-contained JSON file, written by ``run --suite S ... --submission FILE``::

    {"format": "cabinbench-submission/1",
     "suite": {"name": "classic", "version": 1, "layout_hashes": {layout: hash, ...}},
     "baseline": {"name": ..., "config": {...}, "entry_point": "pkg.module:Class" or null},
     "protocol": "sequential", "n_agents": 1,
     "packages": {"python": ..., "cabinbench": ..., "numpy": ..., ...},
     "records": [one record per episode, as in results/runs/*.jsonl],
     "files": {name: {"sha256": ..., "base64": ...}, ...}    only where the baseline reads files
     "checksum": "sha256:<hex>"}

``files`` carries what the baseline's config names and its replay reads: a ``path`` run's plans, an ``onnx``
run's model (:mod:`.submission_files`); the replay uses these, and a changed plan or model replays otherwise.

The checksum is the SHA-256 of the canonical JSON (sorted keys, no spaces) of everything else: it
finds a file changed by accident, not one changed on purpose (anyone recomputes it). Honesty comes
from the replay: every episode is deterministic, and a submission is shown as verified only when
all of its episodes were replayed and matched. ``leaderboard --add`` checks it against the suite as
shipped (:func:`check`), then files it in ``results/submissions/``; ``leaderboard --verify``
replays its episodes (:func:`verify`).

The protocol (:mod:`cabinbench.suites`): every layout of the suite, the same number N of episodes
on each, from base seed 0, so the layout at position p plays the episode seeds p*N ... p*N+N-1; each
episode with its layout's step limit (the suite manifest's) and the suite's start (random, or the
layout's own in classic).
"""

from __future__ import annotations

import hashlib
import json
import math
import platform
from importlib.metadata import PackageNotFoundError, entry_points, version
from pathlib import Path

import numpy as np

from cabinbench.agents import ENTRY_POINT_GROUP, registered_baselines
from cabinbench.errors import LayoutError
from cabinbench.layouts.resolve import load_layout
from cabinbench.layouts.suites import Suite, get_suite
from cabinbench.leaderboard.submission_files import FIELD as FILES
from cabinbench.leaderboard.submission_files import SubmissionError, carried, carry, identity, replay_config
from cabinbench.metrics import METRICS, TEAM_METRICS
from cabinbench.records import RECORD_FIELDS, metric_problem, safe_name
from cabinbench.values import is_whole_number
from cabinbench.version import __version__

FORMAT = "cabinbench-submission/1"
PACKAGES = ("numpy", "scipy", "pymunk", "gymnasium", "pettingzoo")  # what an episode's numbers depend on
VERIFIED_SUFFIX = ".verification.json"
NOT_REPLAYED = ("wall_time",)  # real seconds: the speed of the machine, not the outcome of the episode


def checksum(body: dict) -> str:
    content = {key: value for key, value in body.items() if key != "checksum"}
    text = json.dumps(content, sort_keys=True, separators=(",", ":"), allow_nan=False)
    return "sha256:" + hashlib.sha256(text.encode("utf-8")).hexdigest()


def entry_point(spec: str) -> tuple[str | None, dict]:
    """(``module:Class`` of a baseline, the version of the distribution that registers it)."""
    if ":" in spec:
        return spec, {}
    for point in entry_points(group=ENTRY_POINT_GROUP):
        if point.name == spec:
            dist = {point.dist.name: point.dist.version} if point.dist is not None else {}
            return point.value, dist
    return None, {}


def package_versions(extra: dict) -> dict:
    versions = {"python": platform.python_version(), "cabinbench": __version__}
    for name in PACKAGES:
        try:
            versions[name] = version(name)
        except PackageNotFoundError:
            versions[name] = None
    return {**versions, **extra}


def write_submission(path: Path, records: list[dict], spec: str, suite: Suite) -> dict:
    """Write the records of a ``run --suite`` as a submission at ``path``; return its content."""
    first = records[0]
    point, dist = entry_point(spec)
    body = {
        "format": FORMAT,
        "suite": {"name": suite.name, "version": suite.version, "layout_hashes": suite.content_hashes()},
        "baseline": {"name": spec, "config": first["baseline_config"], "entry_point": point},
        "protocol": first["protocol"],
        "n_agents": first["n_agents"],
        "packages": package_versions(dist),
        "records": records,
    }
    files = carry(spec, first["baseline_config"])
    if files:  # a plan or a model the replay needs
        body[FILES] = files
    body["checksum"] = checksum(body)
    path.write_text(json.dumps(body, indent=1, allow_nan=False) + "\n", encoding="utf-8")
    return body


def read(path: Path) -> dict:
    """A submission file's content, or a one-line error if it is not one."""
    try:
        body = json.loads(Path(path).read_text(encoding="utf-8"), parse_constant=_not_json)
    except FileNotFoundError:
        raise SubmissionError(f"{path}: no such file") from None
    except IsADirectoryError:
        raise SubmissionError(f"{path}: is a folder; give the submission file (FILE.json)") from None
    except OSError as error:
        raise SubmissionError(f"{path}: cannot read it ({error.strerror})") from None
    except (json.JSONDecodeError, UnicodeDecodeError) as error:
        raise SubmissionError(f"{path}: not a JSON file ({error})") from None
    except ValueError as error:  # NaN or Infinity, which json reads but JSON has not
        raise SubmissionError(f"{path}: {error}; a record's numbers must be finite") from None
    if not isinstance(body, dict) or body.get("format") != FORMAT:
        raise SubmissionError(f'{path}: not a cabinbench submission (no "format": "{FORMAT}")')
    return body


def _not_json(constant: str):
    raise ValueError(f"{constant} is not a JSON number")


def metric_names(n_agents: int) -> tuple[str, ...]:
    return (*METRICS, *TEAM_METRICS) if n_agents > 1 else METRICS


def check_record(index: int, record, body: dict) -> None:
    """A well-formed record of this submission's entry."""
    if not isinstance(record, dict):
        raise SubmissionError(f"record {index}: not a JSON object")
    expected = {
        "baseline": body["baseline"]["name"],
        "baseline_config": body["baseline"]["config"],
        "protocol": body["protocol"],
        "n_agents": body["n_agents"],
    }
    for name in (*RECORD_FIELDS, *metric_names(body["n_agents"])):
        if name not in record:
            raise SubmissionError(f"record {index}: field {name!r} missing")
    for name, value in expected.items():
        if record[name] != value:
            raise SubmissionError(
                f"record {index}: {name} {record[name]!r} differs from the submission's {value!r}"
            )
    for name in ("layout", "layout_hash"):
        if not isinstance(record[name], str):
            raise SubmissionError(f"record {index}: {name} {record[name]!r} is not a string")
    for name in ("seed", "episode"):
        if not (is_whole_number(record[name]) and record[name] >= 0):
            raise SubmissionError(f"record {index}: {name} {record[name]!r} is not a whole number >= 0")
    for name in metric_names(body["n_agents"]):
        problem = metric_problem(name, record[name])
        if problem:
            raise SubmissionError(f"record {index}: {name} {record[name]!r} is {problem}")
    if not 0 <= record["coverage"] <= 1:
        raise SubmissionError(f"record {index}: coverage {record['coverage']!r} is outside [0, 1]")


HEADER = {
    "suite": dict,
    "suite.name": str,
    "suite.version": int,
    "suite.layout_hashes": dict,
    "baseline": dict,
    "baseline.name": str,
    "baseline.config": dict,
    "baseline.entry_point": (str, type(None)),
    "protocol": str,
    "n_agents": int,
    "packages": dict,
    "records": list,
}
"""The fields around the records, as :func:`write_submission` writes them (a dotted name is a field of a
field), and their JSON types."""
JSON_TYPES = {dict: "an object", str: "a string", int: "a whole number", list: "a list", type(None): "null"}


def check_header(body: dict, path: Path) -> None:
    """The fields of :data:`HEADER` are there, each of its type; ``n_agents`` is at least 1."""
    for name, types in HEADER.items():
        *parents, field = name.split(".")
        holder = body
        for parent in parents:  # checked before as an object: HEADER lists a field before its fields
            holder = holder[parent]
        if field not in holder:
            raise SubmissionError(f"{path}: field {name!r} missing")
        value, types = holder[field], types if isinstance(types, tuple) else (types,)
        if not isinstance(value, types) or isinstance(value, bool):
            expected = " or ".join(JSON_TYPES[kind] for kind in types)
            raise SubmissionError(f"{path}: field {name!r} is {json.dumps(value)[:40]}, not {expected}")
    if body["n_agents"] < 1:
        raise SubmissionError(f"{path}: field 'n_agents' is {body['n_agents']}, not a whole number >= 1")


def check_protocol(index: int, record: dict, suite: Suite) -> None:
    """The record's episode ran as the suite's protocol has it: the layout's own step limit (a longer one
    would cover more, and replay would confirm it) and the protocol's start."""
    config, layout = record["env_config"], record["layout"]
    if not isinstance(config, dict):
        raise SubmissionError(f"record {index}: env_config {config!r} is not an object")
    limit = suite.manifest()[layout]["max_steps"]
    if config.get("max_steps") != limit:
        raise SubmissionError(
            f"record {index}: {layout} ran with max_steps {config.get('max_steps')!r}, the suite's protocol "
            f"gives it {limit}; run it again without --max-steps"
        )
    if bool(config.get("random_start", False)) != suite.random_start:
        start = "a random start" if suite.random_start else "the layout's start"
        raise SubmissionError(
            f"record {index}: {layout} ran from another start than the suite's protocol ({start}); "
            "run it again without --start"
        )


def check(body: dict, path: Path) -> Suite:
    """Everything ``--add`` requires; raises :class:`SubmissionError` naming the first problem."""
    if body.get("checksum") != checksum(body):
        raise SubmissionError(
            f"{path}: checksum does not match the content: the file was changed after it was written"
        )
    check_header(body, path)
    carried(body, path)
    try:
        suite = get_suite(body["suite"]["name"])
    except LayoutError as error:
        raise SubmissionError(f"{path}: {error}") from None
    if body["suite"]["version"] != suite.version:
        raise SubmissionError(
            f"{path}: made for suite {suite.name} version {body['suite']['version']}; "
            f"this cabinbench ships version {suite.version}"
        )
    shipped = suite.content_hashes()
    for layout, given in sorted(body["suite"]["layout_hashes"].items()):
        if shipped.get(layout, given) != given:
            raise SubmissionError(
                f"{path}: layout {layout} has hash {given}, the suite as shipped has {shipped[layout]}; "
                "run it again on the shipped layout"
            )
    records = body["records"]
    if not records:
        raise SubmissionError(f"{path}: no records")
    seeds: dict[str, list[int]] = {}
    for index, record in enumerate(records):
        check_record(index, record, body)
        layout = record["layout"]
        if record["suite"] != suite.name:
            raise SubmissionError(
                f"record {index}: suite {record['suite']!r}, not the submission's {suite.name}"
            )
        if layout not in shipped:
            raise SubmissionError(f"record {index}: layout {layout!r} is not in suite {suite.name}")
        if record["layout_hash"] != shipped[layout]:
            raise SubmissionError(
                f"record {index}: layout {layout} hash {record['layout_hash']}, the suite as shipped has "
                f"{shipped[layout]}; run it again on the shipped layout"
            )
        check_protocol(index, record, suite)
        seeds.setdefault(layout, []).append(record["seed"] + record["episode"])
    per_layout = len(seeds.get(suite.layout_names[0], []))
    for position, layout in enumerate(suite.layout_names):
        found = seeds.get(layout, [])
        if not found:
            raise SubmissionError(f"{path}: layout {layout} of suite {suite.name} has no episodes")
        repeated = sorted({seed for seed in found if found.count(seed) > 1})
        if repeated:
            raise SubmissionError(
                f"{path}: layout {layout}: episode seed(s) {repeated} recorded more than once"
            )
        protocol = list(range(position * per_layout, (position + 1) * per_layout))
        if sorted(found) != protocol:
            missing = sorted(set(protocol) - set(found))
            extra = sorted(set(found) - set(protocol))
            raise SubmissionError(
                f"{path}: layout {layout}: the protocol's episode seeds are {protocol} "
                f"(run --suite {suite.name} --seed 0 --episodes-per-layout {per_layout}); "
                f"missing {missing}, not in the protocol {extra}"
            )
    return suite


def filed_name(body: dict) -> str:
    """One file per entry: suite, baseline, its config (and the files it carries), protocol and K."""
    config = hashlib.sha256(json.dumps(identity(body), sort_keys=True).encode()).hexdigest()[:8]
    parts = [
        body["suite"]["name"],
        body["baseline"]["name"],
        config,
        body["protocol"],
        f"k{body['n_agents']}",
    ]
    return "__".join(map(safe_name, parts)) + ".json"


def add(path: Path, folder: Path) -> Path:
    """Check the submission at ``path`` and copy it into ``folder``; return where it was filed."""
    body = read(path)
    check(body, path)
    target = folder / filed_name(body)
    if target.exists():
        same = read(target).get("checksum") == body["checksum"]
        what = "this submission is" if same else "an entry of this baseline, config, protocol and K is"
        raise SubmissionError(
            f"{path}: {what} already filed as {target}; remove that file first to replace it"
        )
    folder.mkdir(parents=True, exist_ok=True)
    target.write_bytes(Path(path).read_bytes())
    return target


def filed(folder: Path) -> list[tuple[Path, dict]]:
    """The submissions filed in ``folder`` (none when it does not exist), in name order."""
    return [
        (path, read(path))
        for path in sorted(folder.glob("*.json"))
        if not path.name.endswith(VERIFIED_SUFFIX)
    ]


def status(path: Path, body: dict) -> str:
    """``verified (M of M replayed)`` when a replay of every one of the M episodes matched this exact
    file; ``unverified (N of M replayed)`` when only N were replayed (they matched, the others may
    not); ``unverified (replay differs)``; else ``unverified``."""
    result = path.with_name(path.stem + VERIFIED_SUFFIX)
    if not result.exists():
        return "unverified"
    verification = json.loads(result.read_text(encoding="utf-8"))
    if verification.get("checksum") != body["checksum"]:
        return "unverified"
    if verification["mismatches"]:
        return "unverified (replay differs)"
    return replayed_status(len(verification["episodes"]), len(body["records"]))


def replayed_status(replayed: int, total: int) -> str:
    """The status of a replay of ``replayed`` of a submission's ``total`` episodes that all matched."""
    return f"{'verified' if replayed == total else 'unverified'} ({replayed} of {total} replayed)"


def same(submitted, replayed) -> bool:
    if isinstance(submitted, float) or isinstance(replayed, float):
        if submitted is None or replayed is None:
            return submitted is replayed
        return math.isclose(submitted, replayed, rel_tol=1e-9, abs_tol=1e-12)
    return submitted == replayed


def verify(path: Path, episodes: int | None, seed: int, folder: Path) -> tuple[list[str], list[str], int]:
    """Replay every episode of the submission at ``path`` (``episodes`` None), or ``episodes`` of them
    chosen at random (generator seeded with ``seed``), and compare every metric with its record;
    return (the episodes played, one line per metric that differs, the submission's episodes).
    Every episode is deterministic, so only a replay of all of them verifies the file: its checksum
    is a plain SHA-256 that anyone who changes a record can recompute. When ``path`` is filed in
    ``folder`` the result is kept beside it (``<name>.verification.json``) and the entry shows it."""
    from cabinbench.episodes import (
        run_episode,  # here: replaying needs the envs, reading a submission does not
    )

    body = read(path)
    check(body, path)
    spec = body["baseline"]["name"]
    if spec not in registered_baselines() and ":" not in spec:
        point = body["baseline"]["entry_point"]
        raise SubmissionError(
            f"{path}: baseline {spec!r} is not installed here"
            + (f"; install the package that provides {point}" if point else "")
        )
    records = body["records"]
    rng = np.random.default_rng(seed)
    size = len(records) if episodes is None else min(episodes, len(records))
    chosen = sorted(rng.choice(len(records), size=size, replace=False).tolist())
    played, mismatches = [], []
    with replay_config(body, path) as config:  # the files it carries, never ones of this machine
        for index in chosen:
            record = records[index]
            episode_seed = record["seed"] + record["episode"]
            replayed, _ = run_episode(
                spec,
                load_layout(record["layout"]),
                episode_seed,
                record["protocol"],
                record["n_agents"],
                record["env_config"],
                config,
            )
            played.append(f"{record['layout']} seed {episode_seed}")
            for name in metric_names(record["n_agents"]):
                if name not in NOT_REPLAYED and not same(record[name], replayed.get(name)):
                    mismatches.append(
                        f"{record['layout']} seed {episode_seed}: {name} submitted {record[name]!r}, "
                        f"replayed {replayed.get(name)!r}"
                    )
    target = folder / filed_name(body)
    if target.exists() and read(target).get("checksum") == body["checksum"]:
        result = {"checksum": body["checksum"], "seed": seed, "episodes": played, "mismatches": mismatches}
        target.with_name(target.stem + VERIFIED_SUFFIX).write_text(json.dumps(result, indent=1) + "\n")
    return played, mismatches, len(records)
