"""What every executor is (:mod:`cabinbench.executors`): a context manager that maps a function over
jobs and yields outcomes as they finish."""

from __future__ import annotations

from abc import ABC, abstractmethod
from collections.abc import Callable, Iterable, Iterator
from dataclasses import dataclass
from typing import Any


@dataclass(frozen=True)
class JobFailure:
    """A job whose process died before it finished (``message``: one line, what happened)."""

    job: Any
    message: str


class Executor(ABC):
    """Base class: runs ``function`` over ``jobs``; see the module docstring."""

    name = ""

    @abstractmethod
    def map(self, function: Callable, jobs: Iterable) -> Iterator:
        """Yield each job's outcome (or a :class:`JobFailure`) in completion order."""

    def close(self) -> None:  # noqa: B027 (an executor that starts nothing has nothing to stop)
        """Stop what the executor started (workers, a Ray instance); idempotent."""

    def __enter__(self):
        return self

    def __exit__(self, *_) -> None:
        self.close()
