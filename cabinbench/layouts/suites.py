"""Suites: named, versioned lists of layouts to evaluate on, ``python -m cabinbench.suites``.

    python -m cabinbench.suites [--json] [--png SUITE FILE] [--verify SUITE] [--write-manifests]

A suite is a small YAML file in ``layouts/suites/``: its ``name``, ``version`` and
``description``, and either a ``family`` (:mod:`cabinbench.layouts.family`) with the ``indices``
``[first, stop)`` it draws, or a list of ``layouts`` by name. Beside each generated suite lies its
manifest, ``<name>.manifest.json``: every layout's name, content hash and summary (seat
configuration, size, coverable area, step limit, complexity), written by ``--write-manifests``
and checked against the generator by the tests and by ``--verify``. Listing reads the manifests,
so it costs no generation.

Shipped suites:

- ``cabin-v1-train``: 500 layouts of the family ``cabin_v1`` (2-2, 3-3, 2-3-2, 3-3-3), for training;
- ``cabin-v1-test``: 100 layouts of ``cabin_v1`` from indices train never draws, disjoint from
  train by content hash (tested);
- ``cabin-v1-val``: 50 layouts of ``cabin_v1`` in no other suite (by content hash): the only layouts
  a training choice (a checkpoint, a setting, a seed) may read;
- ``cabin-v1-ood``: 50 layouts of ``cabin_v1_ood``: seat configurations never in train (2-3,
  3-4-3), longer cabins, about three times the clutter;
- ``classic``: the hand-made built-in layouts.

The layouts of a generated suite are named ``<suite>/<NNNN>`` (``cabin-v1-test/0007``) and load
wherever a layout name does (:func:`cabinbench.layouts.resolve.load_layout`, ``run --layout``, the envs,
``complexity``); ``classic``'s are the built-in names themselves.

``--json`` prints a JSON list, one object per suite; ``--png SUITE FILE`` draws a contact sheet of
the suite's layouts (the first :data:`SHEET_MAX` of a larger suite). Exit status 2 on a user
mistake (an unknown suite, a manifest the generator no longer reproduces), in one line.
"""

from __future__ import annotations

import json
from dataclasses import dataclass
from functools import cache
from pathlib import Path

from cabinbench.errors import LayoutError
from cabinbench.layouts.complexity import layout_complexity
from cabinbench.layouts.family import generate
from cabinbench.layouts.fields import FieldChecker
from cabinbench.layouts.load import available_layouts, builtin_layout_dir, parse_yaml, read_layout, read_text
from cabinbench.layouts.model import Layout
from cabinbench.values import is_whole_number

SUITE_KEYS = {"name", "version", "description", "family", "indices", "layouts"}


def suites_dir() -> Path:
    return builtin_layout_dir() / "suites"


@dataclass(frozen=True)
class Suite:
    """A named, versioned list of layouts."""

    name: str
    version: int
    description: str
    path: str
    family: str | None  # generated suites: the family and the indices [first, stop) it draws
    indices: tuple[int, int] | None
    builtin: tuple[str, ...] | None  # listed suites (classic): layout names

    @property
    def layout_names(self) -> tuple[str, ...]:
        if self.builtin is not None:
            return self.builtin
        return tuple(f"{self.name}/{position:04d}" for position in range(self.indices[1] - self.indices[0]))

    @property
    def random_start(self) -> bool:
        """The protocol's start: a pose drawn from the episode's seed (generated suites), or the layout's
        own (a listed suite: classic's layouts each have their designed start)."""
        return self.builtin is None

    @property
    def families(self) -> tuple[str, ...]:
        return (self.family,) if self.family else ()

    def __len__(self) -> int:
        return len(self.layout_names)

    def layout(self, name_or_position: str | int) -> Layout:
        """One layout of the suite, by its name or its position."""
        position = name_or_position
        if isinstance(name_or_position, str):
            if name_or_position not in self.layout_names:
                raise LayoutError(
                    name_or_position,
                    "<name>",
                    f"not a layout of suite {self.name}",
                    f"use {self.layout_names[0]} ... {self.layout_names[-1]}",
                )
            position = self.layout_names.index(name_or_position)
        if self.builtin is not None:
            return read_layout(available_layouts()[self.builtin[position]])
        return generate(self.family, self.indices[0] + position, name=self.layout_names[position])

    @property
    def manifest_path(self) -> Path:
        return Path(self.path).with_name(f"{self.name}.manifest.json")

    def manifest(self) -> dict[str, dict]:
        """Layout name -> its manifest entry (generated suites: read from the committed file;
        listed suites: computed, the layouts are few)."""
        if self.builtin is not None:
            return {name: manifest_entry(read_layout(available_layouts()[name])) for name in self.builtin}
        return _read_manifest(str(self.manifest_path), self.name)

    def content_hashes(self) -> dict[str, str]:
        return {name: entry["hash"] for name, entry in self.manifest().items()}


def manifest_entry(layout: Layout) -> dict:
    """What a manifest records of a layout; the generator must reproduce all of it."""
    complexity = layout_complexity(layout)
    xmin, ymin, xmax, ymax = layout.extent
    seats = layout.parameters.get("seat_blocks")
    return {
        "hash": layout.content_hash,
        "seats": "-".join(map(str, seats)) if seats else None,
        "size_m": [round(xmax - xmin, 3), round(ymax - ymin, 3)],
        "cells": len(layout.cells),
        "coverable_area_m2": round(layout.coverable_area, 3),
        "max_steps": layout.max_steps,
        "complexity_total": round(complexity.total, 4),
        "complexity_normalized": round(complexity.normalized, 4),
    }


@cache
def _read_manifest(path: str, suite: str) -> dict[str, dict]:
    try:
        manifest = json.loads(Path(path).read_text(encoding="utf-8"))
    except (OSError, json.JSONDecodeError) as error:
        raise LayoutError(
            path, "<file>", f"the suite's manifest cannot be read ({error})", "run --write-manifests"
        ) from None
    return manifest["layouts"]


def _read_suite(path: Path) -> Suite:
    spec = parse_yaml(read_text(path), str(path))
    check = FieldChecker(str(path))
    check.known_keys(spec, SUITE_KEYS, "")
    name = check.string(spec.get("name", path.stem), "name")
    if name != path.stem:
        check.fail("name", f"{name!r} differs from the file name {path.stem!r}", "name the file <name>.yaml")
    version = check.positive_int(spec.get("version"), "version")
    description = check.string(spec.get("description", ""), "description")
    if ("family" in spec) == ("layouts" in spec):
        check.fail("family", "give either family (with indices) or layouts", "see layouts/suites/")
    if "layouts" in spec:
        names = spec["layouts"]
        if not isinstance(names, list) or not names or not all(isinstance(n, str) for n in names):
            check.fail("layouts", f"expected a list of layout names, got {names!r}", "write [a320_cell, ...]")
        return Suite(name, version, description, str(path), None, None, tuple(names))
    family = check.string(spec["family"], "family")
    indices = spec.get("indices")
    if (
        not isinstance(indices, list)
        or len(indices) != 2
        or not all(is_whole_number(i) and i >= 0 for i in indices)
        or indices[1] <= indices[0]
    ):
        check.fail(
            "indices", f"expected [first, stop) with stop > first >= 0, got {indices!r}", "write [0, 500]"
        )
    return Suite(
        name, version, description, str(path), family, None if indices is None else tuple(indices), None
    )


@cache
def available_suites() -> dict[str, Suite]:
    """Suite name -> suite, the shipped ones (``layouts/suites/*.yaml``)."""
    return {path.stem: _read_suite(path) for path in sorted(suites_dir().glob("*.yaml"))}


def get_suite(name: str) -> Suite:
    suites = available_suites()
    if name not in suites:
        raise LayoutError(name, "<suite>", "unknown suite", f"use one of {', '.join(suites)}")
    return suites[name]


def suite_layout(name: str) -> Layout:
    """The layout named ``<suite>/<NNNN>`` (what :func:`cabinbench.load_layout` calls for such names)."""
    suite_name, _, _ = name.rpartition("/")
    suite = get_suite(suite_name)
    if suite.builtin is not None:
        raise LayoutError(
            name, "<name>", f"{suite_name}'s layouts have names of their own", "use e.g. a320_cell"
        )
    return suite.layout(name)


def summary(suite: Suite) -> dict:
    """One suite as ``--json`` lists it."""
    entries = list(suite.manifest().values())

    def span(key: str) -> list[float]:
        values = [entry[key] for entry in entries]
        return [min(values), max(values)]

    return {
        "name": suite.name,
        "version": suite.version,
        "size": len(suite),
        "families": list(suite.families) or ["hand-made"],
        "seats": sorted({entry["seats"] for entry in entries if entry["seats"]}),
        "complexity_total": span("complexity_total"),
        "complexity_normalized": span("complexity_normalized"),
        "coverable_area_m2": span("coverable_area_m2"),
        "first": suite.layout_names[0],
        "description": suite.description,
        "file": suite.path,
    }


def write_manifest(suite: Suite) -> Path:
    """Generate every layout of a generated suite and write its manifest."""
    layouts = {name: manifest_entry(suite.layout(name)) for name in suite.layout_names}
    manifest = {"suite": suite.name, "version": suite.version, "layouts": layouts}
    suite.manifest_path.write_text(json.dumps(manifest, indent=1) + "\n", encoding="utf-8")
    _read_manifest.cache_clear()
    return suite.manifest_path


def verify(suite: Suite, names: list[str] | None = None) -> list[str]:
    """The layouts (all, or ``names``) whose generated entry differs from the manifest's."""
    manifest = suite.manifest()
    return [
        name for name in names or suite.layout_names if manifest_entry(suite.layout(name)) != manifest[name]
    ]


def shared_layouts() -> list[tuple[str, str]]:
    """Pairs of layouts of different suites with the same content hash (none may exist: a test
    layout seen in training would measure memory, not generalisation)."""
    owner: dict[str, str] = {}
    shared = []
    for suite in available_suites().values():
        for name, content_hash in suite.content_hashes().items():
            if content_hash in owner and owner[content_hash].split("/")[0] != suite.name:
                shared.append((owner[content_hash], name))
            owner.setdefault(content_hash, name)
    return shared
