"""The one resolver from what a user names to a :class:`~cabinbench.layouts.model.Layout`: a
built-in or user layout name (``CABINBENCH_LAYOUT_PATH`` first), a suite layout
(``cabin-v1-test/0007``) or the path of a YAML file."""

from __future__ import annotations

import os
from pathlib import Path

from cabinbench.errors import LayoutError
from cabinbench.layouts.load import available_layouts, read_layout
from cabinbench.layouts.model import Layout
from cabinbench.layouts.suites import suite_layout


def load_layout(name_or_path: str | os.PathLike) -> Layout:
    """Load a layout by registered name, by suite layout name (``cabin-v1-test/0007``, see
    :mod:`cabinbench.suites`) or by path to a YAML file."""
    candidate = Path(name_or_path)
    if candidate.suffix in (".yaml", ".yml") or candidate.exists():
        return read_layout(candidate)
    layouts = available_layouts()
    if str(name_or_path) in layouts:
        return read_layout(layouts[str(name_or_path)])
    if "/" in str(name_or_path):
        return suite_layout(str(name_or_path))
    raise LayoutError(
        str(name_or_path),
        "<name>",
        "unknown layout",
        f"use one of {', '.join(layouts)}, a suite layout (cabin-v1-test/0007) or a .yaml path",
    )
