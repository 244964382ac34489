"""The local executor: jobs in this process, or in a local process pool with ``workers > 1``."""

from __future__ import annotations

import os
import signal
import threading
import time
from collections.abc import Callable, Iterable, Iterator
from concurrent.futures import ProcessPoolExecutor, as_completed
from concurrent.futures.process import BrokenProcessPool

from cabinbench.errors import EXIT_INTERRUPTED
from cabinbench.executors.base import Executor, JobFailure

PARENT_POLL_SECONDS = 0.5  # how often a worker checks that the process that started it is still there


class LocalExecutor(Executor):
    """``workers <= 1``: in this process, in order. Otherwise a process pool; when the consumer stops
    early, pending jobs are cancelled. Ctrl-C in a terminal also stops the workers at once; a SIGINT
    sent to the parent alone lets them finish the jobs in hand (not returned) before the process
    exits. Workers end within ``PARENT_POLL_SECONDS`` of their parent, however it ends (even
    ``kill -9``). A worker that dies breaks the pool: its job and every unfinished one fail."""

    name = "local"

    def __init__(self, workers: int = 1, address: str | None = None) -> None:
        if address is not None:
            raise ValueError("the local executor takes no address (that is for --executor ray)")
        self.workers = workers

    def map(self, function: Callable, jobs: Iterable) -> Iterator:
        if self.workers <= 1:
            for job in jobs:
                yield function(job)
            return
        pool = ProcessPoolExecutor(max_workers=self.workers, initializer=_start_worker)
        try:
            futures = {pool.submit(function, job): job for job in jobs}
            for future in as_completed(futures):
                try:
                    result = future.result()
                except BrokenProcessPool:
                    result = JobFailure(futures[future], "a local worker process died")
                yield result
        finally:
            pool.shutdown(wait=False, cancel_futures=True)


def _start_worker() -> None:
    """Run in every worker process as it starts."""
    # Ctrl-C reaches the whole process group. A worker just stops (its job is lost anyway);
    # the parent keeps what is finished. Without this every worker prints a traceback.
    signal.signal(signal.SIGINT, lambda *_: os._exit(EXIT_INTERRUPTED))
    # A parent killed outright (kill -9) cannot stop its pool: the workers watch for it themselves.
    threading.Thread(target=_exit_with_parent, args=(os.getppid(),), daemon=True).start()


def _exit_with_parent(parent: int) -> None:
    while os.getppid() == parent:  # an orphan is handed to another parent
        time.sleep(PARENT_POLL_SECONDS)
    os._exit(EXIT_INTERRUPTED)
