"""Memory a piece of work will need, checked before it is allocated.

Every size a user gives (a layout's rows or extent, a map's pixels, a raster resolution, an
observation patch) is turned into the bytes it will take and compared with :func:`memory_budget`
before anything is allocated; the caller refuses in one line naming its field and fix, with the
sentence :func:`too_much_memory` returns.
"""

from __future__ import annotations

import os

GiB = 2**30
MACHINE_SHARE = (
    0.5  # of physical memory one layout, map or env may take: the process and its peers need the rest
)


def machine_memory() -> int:
    """Physical memory of this machine, bytes."""
    return os.sysconf("SC_PAGE_SIZE") * os.sysconf("SC_PHYS_PAGES")


def memory_budget() -> int:
    """What one piece of work may allocate: :data:`MACHINE_SHARE` of :func:`machine_memory`."""
    return int(machine_memory() * MACHINE_SHARE)


def too_much_memory(needed: float) -> str | None:
    """``None`` when ``needed`` bytes fit the budget; otherwise the sentence that says by how much."""
    if needed <= memory_budget():
        return None
    return (
        f"needs about {_in_units(needed)}, more than the {memory_budget() / GiB:.1f} GiB allowed "
        f"on this machine ({machine_memory() / GiB:.1f} GiB)"
    )


def _in_units(size: float) -> str:
    """``size`` bytes in GiB, or TiB from 1,024 GiB on."""
    return f"{size / GiB:,.1f} GiB" if size < 1024 * GiB else f"{size / (1024 * GiB):,.2f} TiB"
