"""The files a submission's baseline reads (a path's plan, an ONNX policy), carried inside the submission.

A baseline class names the settings of its config that are files in ``config_files`` (``path`` and ``onnx``:
``file``; a setting may give one name, a list of them, or an object of them by layout). ``run --submission``
puts each such file into the submission under the name its records' config gives it::

    "files": {"plans/a320_cell.csv": {"sha256": "<hex>", "base64": "<the file's bytes>"}, ...}

``--add`` checks every carried file against its SHA-256 and, for a baseline installed here, that every file
its config names is carried. ``--verify`` replays the episodes with the carried files (copies in a temporary
folder, each name of the config pointed at its copy), never with a file of the same name on the verifying
machine: a plan or a model changed after the run replays into other metrics and fails verification. The
files' hashes are part of the entry's name, so two plans saved under one file name are two entries.
"""

from __future__ import annotations

import base64
import binascii
import contextlib
import hashlib
import tempfile
from collections.abc import Iterator
from pathlib import Path

from cabinbench.agents import baseline_class
from cabinbench.errors import BaselineError, UsageError

FIELD = "files"


class SubmissionError(UsageError):
    """A submission that cannot be written, filed or verified; one line naming what is wrong (exit 2).
    Defined here, as :mod:`.submissions` imports this module."""


def file_keys(spec: str) -> tuple[str, ...]:
    """The settings of the baseline ``spec``'s config that name files (its class's ``config_files``)."""
    return tuple(getattr(baseline_class(spec), "config_files", ()))


def names_in(value) -> list[str]:
    """The file names a setting gives: a name, a list of them, or an object of them (a plan per layout)."""
    if isinstance(value, str):
        return [value]
    items = value if isinstance(value, list) else list(value.values()) if isinstance(value, dict) else []
    return [name for item in items for name in names_in(item)]


def named_files(spec: str, config: dict) -> list[str]:
    """Every file the config of baseline ``spec`` names, once each, in order."""
    return list(dict.fromkeys(name for key in file_keys(spec) for name in names_in(config.get(key))))


def carry(spec: str, config: dict) -> dict[str, dict]:
    """The ``files`` field of a submission of baseline ``spec`` run with ``config`` (empty when its config
    names no file)."""
    files = {}
    for name in named_files(spec, config):
        try:
            content = Path(name).read_bytes()
        except OSError as error:
            raise SubmissionError(
                f"{name}: cannot read it into the submission ({error.strerror}); run from the folder the "
                "run's --config names it from"
            ) from None
        files[name] = {
            "sha256": hashlib.sha256(content).hexdigest(),
            "base64": base64.b64encode(content).decode("ascii"),
        }
    return files


def carried(body: dict, path: Path) -> dict[str, bytes]:
    """The contents of the files the submission at ``path`` carries, each checked against its SHA-256; and,
    where its baseline is installed here, every file its config names is among them."""
    files = body.get(FIELD, {})
    if not isinstance(files, dict):
        raise SubmissionError(f"{path}: field {FIELD!r} is not an object of file name to its content")
    contents = {}
    for name, entry in files.items():
        if not (
            isinstance(entry, dict) and all(isinstance(entry.get(key), str) for key in ("sha256", "base64"))
        ):
            raise SubmissionError(f'{path}: {FIELD}[{name!r}] is not {{"sha256": HEX, "base64": TEXT}}')
        try:
            content = base64.b64decode(entry["base64"], validate=True)
        except binascii.Error:
            raise SubmissionError(f"{path}: {FIELD}[{name!r}]: its base64 is not base64") from None
        if hashlib.sha256(content).hexdigest() != entry["sha256"]:
            raise SubmissionError(
                f"{path}: file {name}: its content does not match its sha256: it was changed after the run"
            )
        contents[name] = content
    spec = body["baseline"]["name"]
    try:
        missing = [name for name in named_files(spec, body["baseline"]["config"]) if name not in contents]
    except BaselineError:  # not installed here: the replay says so
        missing = []
    if missing:
        raise SubmissionError(
            f"{path}: baseline {spec} reads {missing[0]}, which the submission does not carry; write it "
            "again with run --submission"
        )
    return contents


def identity(body: dict) -> dict:
    """What names a submission's entry: its baseline's config, and the hashes of the files it carries."""
    files = body.get(FIELD)
    config = body["baseline"]["config"]
    return (
        {"config": config, "files": {name: files[name]["sha256"] for name in sorted(files)}}
        if files
        else config
    )


@contextlib.contextmanager
def replay_config(body: dict, path: Path) -> Iterator[dict]:
    """The baseline config that replays the submission at ``path``: its own, every file it names pointed
    at a copy of the carried file, in a temporary folder that lasts while inside."""
    contents = carried(body, path)
    config, keys = body["baseline"]["config"], file_keys(body["baseline"]["name"])
    with tempfile.TemporaryDirectory(prefix="cabinbench-submission-") as folder:
        copies = {}
        for index, (name, content) in enumerate(contents.items()):
            copy = (
                Path(folder) / str(index) / Path(name).name
            )  # its own folder: names may repeat, suffixes tell
            copy.parent.mkdir()
            copy.write_bytes(content)
            copies[name] = str(copy)
        yield {key: repointed(value, copies) if key in keys else value for key, value in config.items()}


def repointed(value, copies: dict[str, str]):
    """A file setting (a name, a list, an object of them) with every name replaced by its copy's."""
    if isinstance(value, str):
        return copies[value]
    if isinstance(value, list):
        return [repointed(item, copies) for item in value]
    if isinstance(value, dict):
        return {key: repointed(item, copies) for key, item in value.items()}
    return value
