"""Executors: what runs independent jobs (the episodes of a run, the seeds of a training sweep).

An executor maps a picklable module-level function over picklable jobs and yields each outcome as
soon as it is finished, in completion order: the function's result, or a :class:`JobFailure` when
the process that ran the job died (the other jobs go on, so a run keeps every finished record).
An exception the function raises is raised again here, as it would be in one process.

``local`` (:mod:`.local`): in this process, or a local process pool with ``workers > 1``.
``ray`` (:mod:`.ray_tasks`): Ray tasks on an existing cluster (``address``) or a local instance;
needs the ``cabinbench[ray]`` extra.

Executors are context managers: leaving one stops what it started.
"""

from __future__ import annotations

from cabinbench.executors.base import Executor


def executors() -> dict[str, type[Executor]]:
    """The executors by name (``--executor``)."""
    from cabinbench.executors.local import LocalExecutor
    from cabinbench.executors.ray_tasks import RayExecutor

    return {executor.name: executor for executor in (LocalExecutor, RayExecutor)}


EXECUTOR_NAMES = ("local", "ray")  # = executors(), for argparse choices without importing them
