"""The Ray executor: each job a Ray task (one CPU), on an existing cluster or a local instance.

``address`` (``--address``): a running cluster (``auto``, or ``HOST:PORT`` of its head); None
starts a local instance for this command, stopped when the executor closes. ``working_dir``: a
folder shipped to every worker as its working folder (Ray's runtime environment), so that what a
job names relative to it (a layout file, a ``package.module:Class`` baseline beside it) resolves
on remote nodes as it does here; cabinbench itself must be installed on every node. What the workers
print, and Ray's notices (a worker died ...), appear on this process's stdout.

A task is not retried (``max_retries=0``): a job whose worker dies fails with one line rather than
running again, perhaps to die again, unseen.
"""

from __future__ import annotations

import logging
import socket
from collections.abc import Callable, Iterable, Iterator

from cabinbench.errors import UsageError
from cabinbench.executors.base import Executor, JobFailure

INSTALL = 'pip install "cabinbench[ray]"'
SHIPPED_EXCLUDES = [".git", ".venv*", "__pycache__", "*.egg-info"]  # never needed by a worker
NO_CLUSTER = (
    "no Ray cluster to join there ({reason}); start one with 'ray start --head', or leave --address out "
    "for a local instance"
)


class RayExecutor(Executor):
    name = "ray"

    def __init__(self, workers: int = 1, address: str | None = None, working_dir: str | None = None) -> None:
        """``workers`` is the local executor's; Ray runs as many tasks at once as the cluster has CPUs."""
        try:
            import ray
        except ImportError:
            raise UsageError(f"--executor ray needs Ray, which is not installed: {INSTALL}") from None
        self.ray = ray
        runtime_env = {"working_dir": working_dir, "excludes": SHIPPED_EXCLUDES} if working_dir else None
        if address is not None and (refusal := _unreachable(address)):
            raise UsageError(f"--address {address}: {NO_CLUSTER.format(reason=refusal)}")
        try:
            ray.init(
                address=address or "local",  # not a cluster that happens to run on this machine
                runtime_env=runtime_env,
                include_dashboard=False if address is None else None,
                logging_level=logging.WARNING,
                configure_logging=True,
            )
        except ConnectionError as error:
            if "InvalidAuthToken" in str(error.__cause__):
                # Ray sends its token to an address given by hand only when RAY_AUTH_MODE says so.
                raise UsageError(
                    f"--address {address}: the Ray cluster there asks for its authentication token; run with "
                    "RAY_AUTH_MODE=token and the cluster's token in ~/.ray/auth_token (or RAY_AUTH_TOKEN), "
                    "or with --address auto on one of its nodes"
                ) from None
            raise UsageError(f"--address {address}: {NO_CLUSTER.format(reason=_first_line(error))}") from None

    def map(self, function: Callable, jobs: Iterable) -> Iterator:
        ray = self.ray
        task = ray.remote(num_cpus=1, max_retries=0)(function)
        pending = {task.remote(job): job for job in jobs}
        try:
            while pending:
                [done], _ = ray.wait(list(pending), num_returns=1)
                job = pending.pop(done)
                try:
                    outcome = ray.get(done)
                except ray.exceptions.RayTaskError:  # the job's own exception: raised, as it is locally
                    raise
                except ray.exceptions.RayError as error:  # its worker or node died
                    outcome = JobFailure(job, f"its Ray worker died ({type(error).__name__})")
                yield outcome
        finally:
            for ref in pending:
                ray.cancel(ref, force=True)

    def close(self) -> None:
        if self.ray.is_initialized():
            self.ray.shutdown()


def _first_line(error: Exception) -> str:
    return (str(error).strip().splitlines() or [type(error).__name__])[0]


def _unreachable(address: str) -> str | None:
    """Why nothing answers at ``HOST:PORT``, or None (also for any other form of address). Ray itself
    retries a silent address for about a quarter of an hour before it gives up."""
    host, colon, port = address.rpartition(":")
    if not colon or not port.isdigit() or "://" in address:
        return None
    try:
        socket.create_connection((host.strip("[]"), int(port)), timeout=5).close()  # [IPv6]:PORT too
    except OSError as error:
        return error.strerror or type(error).__name__
    return None
