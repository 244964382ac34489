"""What the command lines share: every user mistake is one line on stderr, exit status 2.

A command builds its parser with :class:`ArgumentParser` (a bad argument: one line, no usage
block), checks what it can in the argument types below (before any work starts), and wraps its
``main`` in :func:`user_errors`, which prints a :class:`~cabinbench.errors.UserError` as one line (and
Ctrl-C as ``interrupted``, exit status 130, where the command has nothing better to say; a Ctrl-C
that arrives inside the simulation is raised as it returns: it would be lost there).
"""

from __future__ import annotations

import argparse
import contextlib
import functools
import json
import os
import sys
import tempfile
import warnings
from collections.abc import Callable, Iterator
from pathlib import Path

from cabinbench.errors import EXIT_INTERRUPTED, EXIT_USAGE, UsageError, UserError
from cabinbench.sim.interrupts import reliable_ctrl_c


class ArgumentParser(argparse.ArgumentParser):
    """``argparse.ArgumentParser`` whose errors are one line."""

    def error(self, message: str):
        self.exit(EXIT_USAGE, f"{self.prog}: error: {message} (see --help)\n")


def user_errors(main: Callable[[list[str] | None], int]) -> Callable[[list[str] | None], int]:
    """``main`` that prints a user error as one line and returns :data:`EXIT_USAGE`, and a Ctrl-C
    that ``main`` does not handle itself as ``interrupted`` (:data:`EXIT_INTERRUPTED`). Ctrl-C is
    raised where Python can pass it on (:mod:`cabinbench.sim.interrupts`), so it is never lost."""

    @functools.wraps(main)
    def checked(argv: list[str] | None = None) -> int:
        try:
            with reliable_ctrl_c():
                return main(argv)
        except UserError as error:
            print(f"error: {error}", file=sys.stderr)
            return EXIT_USAGE
        except KeyboardInterrupt:
            print("interrupted", file=sys.stderr)
            return EXIT_INTERRUPTED

    return checked


@contextlib.contextmanager
def warnings_as_lines(category: type[Warning]) -> Iterator[None]:
    """Inside the block each warning of ``category`` is one line on stderr, ``warning: ...``, every
    time it is raised (a skipped record, named by file and line, is the user's to fix)."""
    with warnings.catch_warnings():
        warnings.simplefilter("always", category)
        show = warnings.showwarning

        def one_line(message, kind, *rest, **options):
            if issubclass(kind, category):
                print(f"warning: {message}", file=sys.stderr)
            else:
                show(message, kind, *rest, **options)

        warnings.showwarning = one_line  # catch_warnings puts the original back
        yield


def positive_int(text: str) -> int:
    """argparse type: a whole number >= 1."""
    return _whole_number(text, 1)


def non_negative_int(text: str) -> int:
    """argparse type: a whole number >= 0."""
    return _whole_number(text, 0)


def positive_number(text: str) -> float:
    """argparse type: a number > 0."""
    try:
        value = float(text)
    except ValueError:
        value = None
    if value is None or not value > 0 or value == float("inf"):
        raise argparse.ArgumentTypeError(f"{text!r} is not a number > 0")
    return value


def _whole_number(text: str, least: int) -> int:
    try:
        value = int(text)
    except ValueError:
        value = None
    if value is None or value < least:
        raise argparse.ArgumentTypeError(f"{text!r} is not a whole number >= {least}")
    return value


def json_object(text: str) -> dict:
    """argparse type: a JSON object."""
    try:
        value = json.loads(text)
    except json.JSONDecodeError as error:
        raise argparse.ArgumentTypeError(
            f"not valid JSON ({error}): write e.g. '{{\"min_turn\": 0.5}}'"
        ) from None
    if not isinstance(value, dict):
        raise argparse.ArgumentTypeError(f"{text!r} is not a JSON object: write e.g. '{{\"min_turn\": 0.5}}'")
    return value


def output_folder(text: str) -> Path:
    """argparse type: a folder that exists or can be created (no file in the way), and that this
    process can write in (tried, not inferred from permissions: root may write where the mode bits
    say no, and nobody writes under /proc)."""
    path = Path(text)
    for part in (path, *path.parents):
        if part.exists():
            if not part.is_dir():
                raise argparse.ArgumentTypeError(f"{part} is a file, not a folder: give a folder")
            _check_writable(part, text)
            break
    return path


def output_file(*suffixes: str) -> Callable[[str], Path]:
    """argparse type: a file to write, named with one of ``suffixes``, in a folder that exists and
    that this process can write in (see :func:`output_folder`)."""

    def check(text: str) -> Path:
        path = Path(text)
        if path.suffix.lower() not in suffixes:
            raise argparse.ArgumentTypeError(f"{text!r}: give a file name ending in {' or '.join(suffixes)}")
        if path.is_dir():
            raise argparse.ArgumentTypeError(f"{text!r} is a folder: give a file name")
        if not path.parent.is_dir():
            raise argparse.ArgumentTypeError(f"{text!r}: no folder {path.parent}; create it first")
        _check_writable(path.parent, text)
        return path

    return check


def checked_output(option: str, check: Callable[[str], Path], text: str) -> Path:
    """``check(text)`` (:func:`output_folder` or an :func:`output_file`) for a path argparse did not
    check itself (a default used by only some actions, one of several values), its complaint a
    :class:`UsageError` naming ``option``."""
    try:
        return check(text)
    except argparse.ArgumentTypeError as error:
        raise UsageError(f"{option}: {error}") from None


def _check_writable(folder: Path, given: str) -> None:
    """Create and remove a file in ``folder``; a folder that refuses it is the user's to change."""
    try:
        descriptor, probe = tempfile.mkstemp(prefix=".cabinbench-probe-", dir=folder)
    except OSError as error:
        raise argparse.ArgumentTypeError(
            f"{given!r}: cannot write in {folder} ({error.strerror}); give a folder you can write in"
        ) from None
    os.close(descriptor)
    os.unlink(probe)
