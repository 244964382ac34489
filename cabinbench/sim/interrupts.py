"""Ctrl-C raised only where Python can pass it on: never lost, never a crash.

Python raises ``KeyboardInterrupt`` wherever the main thread is when SIGINT arrives, and some of the
places the simulation runs cannot take it. pymunk calls its collision handlers through cffi, which
prints an exception raised in one and carries on (the key press is lost: the run goes on to its
end). Raised inside pymunk's destructor of a body, it leaves the body half freed, and a later
garbage collection crashes the process (a segmentation fault). numba's dispatcher turns it into a
``SystemError``. So, inside :func:`reliable_ctrl_c` (every command runs in it):

- the simulation's entry points (:class:`~cabinbench.sim.world.World`'s methods) are
  :func:`shielded`: a Ctrl-C that arrives inside one is noted and raised as that call returns, at
  most one env step later;
- one that arrives elsewhere in pymunk or numba (a destructor run by the garbage collector) is sent
  again a moment later, as is one raised where Python cannot pass it on (any other destructor).

Everywhere else it is raised at once, as by Python's own handler.
"""

from __future__ import annotations

import _thread
import contextlib
import functools
import importlib.util
import signal
import sys
import threading
from collections.abc import Callable, Iterator
from typing import TypeVar

Method = TypeVar("Method", bound=Callable)

AGAIN_SECONDS = 0.01  # how soon a Ctrl-C that could not be raised is sent again
# the folders of the code that must not be stopped half way (found, not imported: a command that
# never simulates does not load pymunk)
UNSTOPPABLE = tuple(
    importlib.util.find_spec(package).submodule_search_locations[0] for package in ("pymunk", "numba")
)

_noted = False  # a Ctrl-C arrived while the main thread was inside a shielded call


def shielded(method: Method) -> Method:
    """``method`` that raises a Ctrl-C noted during it as it returns (see the module docstring)."""

    @functools.wraps(method)
    def call(*args, **kwargs):
        result = method(*args, **kwargs)
        if _noted:
            _raise_noted()
        return result

    return call


_SHIELDED_CODE = shielded(lambda: None).__code__  # every shielded call runs this code object


def _raise_noted() -> None:
    global _noted
    # a worker thread's call returns here too; the Ctrl-C is the main thread's to raise
    if threading.current_thread() is threading.main_thread():
        _noted = False
        raise KeyboardInterrupt


def _send_again() -> None:
    """SIGINT to the main thread in a moment, from another thread: sent from the code that could not
    take it, it would arrive there again."""
    again = threading.Timer(AGAIN_SECONDS, _thread.interrupt_main, (signal.SIGINT,))
    again.daemon = True
    again.start()


def _on_ctrl_c(signum, frame) -> None:
    """SIGINT handler; ``frame`` is where the main thread is."""
    global _noted
    unstoppable = False
    while frame is not None:
        if frame.f_code is _SHIELDED_CODE:
            _noted = True
            return
        unstoppable = unstoppable or frame.f_code.co_filename.startswith(UNSTOPPABLE)
        frame = frame.f_back
    if unstoppable:
        _send_again()
        return
    raise KeyboardInterrupt


@contextlib.contextmanager
def reliable_ctrl_c() -> Iterator[None]:
    """Inside the block, Ctrl-C is raised where it can be (see the module docstring). Only where
    Python's own handler is in place, in the main thread: an ignored SIGINT (a background job) stays
    ignored."""
    global _noted
    ours = (
        threading.current_thread() is threading.main_thread()
        and signal.getsignal(signal.SIGINT) is signal.default_int_handler
    )
    if not ours:
        yield
        return
    hook = sys.unraisablehook

    def send_again_if_ctrl_c(unraisable) -> None:
        if issubclass(unraisable.exc_type, KeyboardInterrupt):
            _send_again()
        else:
            hook(unraisable)

    sys.unraisablehook = send_again_if_ctrl_c
    signal.signal(signal.SIGINT, _on_ctrl_c)
    try:
        yield
    finally:
        signal.signal(signal.SIGINT, signal.default_int_handler)
        sys.unraisablehook = hook
        _noted = False  # noted in a call that raised something else: not for whatever runs next
