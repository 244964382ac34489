"""What counts as a number among the values users give: layout fields, env and baseline arguments,
submission records.

YAML and JSON read ``true`` and ``false`` as bools, which Python counts as the ints 1 and 0: a
user's ``true`` is never a number here.
"""

from __future__ import annotations

import math


def is_whole_number(value) -> bool:
    """An int, not a bool."""
    return isinstance(value, int) and not isinstance(value, bool)


def is_real_number(value) -> bool:
    """A finite int or float, not a bool."""
    return isinstance(value, (int, float)) and not isinstance(value, bool) and math.isfinite(value)
