"""Navigation complexity (the study's §4.1): Shannon entropy of each free cell's 8-neighbourhood.

On an occupancy grid whose cells are robot-sized, a free cell with n occupied neighbours among
its 8 (neighbours outside the map count as free, as Eq. 4.7 shows) has p = n / 8 and
H = -p log2 p - (1 - p) log2 (1 - p), 0 when p is 0 or 1; obstacle cells score 0. ``total`` is
the sum of H, ``normalized`` is total / (rows × cols). The study's Table 4.1: 4.4859 (Matrix A)
and 11.1065 (Matrix B); its Table 4.2 (the cabin map, 257.8176 / 0.4855): see the built-in
layout ``paper_cabin_map``.

The grid is :meth:`~cabinbench.layouts.model.Layout.normalized_map`: a ``grid`` layout's map as its
author wrote it; any other layout rasterised so that a robot-sized cell is free when the robot's
centre can stand somewhere in it. That rule keeps every legroom gap the robot can enter free
(a gap a little wider than the robot leaves its centre a strip only centimetres wide, which a
rule "occupied when any obstacle touches the cell" loses), and marks floor the robot cannot reach
as obstacle. The neighbour count is one convolution, the rasterisation one ``bincount`` over the
coverage raster: no per-pixel Python loop.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy import ndimage

from cabinbench.layouts.model import Layout


@dataclass(frozen=True)
class Complexity:
    cell_map: np.ndarray  # H per grid cell, rows bottom to top
    occupancy: np.ndarray  # True where occupied

    @property
    def total(self) -> float:
        return float(self.cell_map.sum())

    @property
    def normalized(self) -> float:
        return self.total / self.cell_map.size


def grid_complexity(occupancy: np.ndarray) -> Complexity:
    """Complexity of a boolean occupancy grid (True = obstacle)."""
    occupancy = np.asarray(occupancy, dtype=bool)
    neighbours = np.ones((3, 3))
    neighbours[1, 1] = 0
    occupied_neighbours = ndimage.convolve(occupancy.astype(float), neighbours, mode="constant", cval=0.0)
    p = occupied_neighbours / 8.0
    with np.errstate(divide="ignore", invalid="ignore"):
        entropy = -p * np.log2(p) - (1 - p) * np.log2(1 - p)
    entropy = np.nan_to_num(entropy, nan=0.0)  # p = 0 or 1 gives 0·log 0
    entropy[occupancy] = 0.0
    return Complexity(entropy, occupancy)


def layout_complexity(layout: Layout) -> Complexity:
    """Complexity of a layout's normalised map (robot-sized cells, see the module doc)."""
    return grid_complexity(layout.normalized_map())


def map_rows(occupancy: np.ndarray) -> list[str]:
    """The grid as a ``grid`` layout writes it: ``#`` obstacle, ``.`` free, top row first."""
    return ["".join("#" if blocked else "." for blocked in row) for row in occupancy[::-1]]


def save_complexity_png(result: Complexity, path: str, title: str = "") -> None:
    """The complexity map (like the study's Fig. 5.5(c)): obstacles dark, free cells by H."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    rows, cols = result.cell_map.shape
    figure, axes = plt.subplots(figsize=(max(4, cols * 0.25), max(2.5, rows * 0.25 + 1)))
    shown = np.ma.masked_where(result.occupancy, result.cell_map)
    colour_map = plt.get_cmap("viridis").with_extremes(bad=(0.2, 0.2, 0.25))
    image = axes.imshow(shown, origin="lower", cmap=colour_map, vmin=0, vmax=1)
    figure.colorbar(image, ax=axes, label="H (bits)", shrink=0.8)
    axes.set_title(f"{title}  total {result.total:.4f}, normalized {result.normalized:.4f}")
    axes.set_xlabel("cell (robot diameters)")
    figure.tight_layout()
    figure.savefig(path, dpi=120)
    plt.close(figure)


def layout_summary(layout: Layout) -> dict:
    """One layout as ``python -m cabinbench.layouts`` lists it."""
    complexity = layout_complexity(layout)
    xmin, ymin, xmax, ymax = layout.extent
    return {
        "name": layout.name,
        "kind": layout.kind,
        "size_m": [round(xmax - xmin, 3), round(ymax - ymin, 3)],
        "cells": len(layout.cells),
        "goals": len(layout.goals),
        "free_area_m2": round(layout.free_area, 3),
        "coverable_area_m2": round(layout.coverable_area, 3),
        "complexity_total": round(complexity.total, 4),
        "complexity_normalized": round(complexity.normalized, 4),
        "max_steps": layout.max_steps,
        "file": layout.path,
    }
