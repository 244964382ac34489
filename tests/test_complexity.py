"""Navigation complexity reproduces the seed's Table 4.1 and Eq. 4.7/4.8."""

import json

import numpy as np
import pytest

from cabinbench.complexity import grid_complexity, layout_complexity, main
from cabinbench.layout import load_layout


def test_table_4_1_values():
    # to 3 decimals, as printed in the seed (4.4859, 11.1065)
    assert layout_complexity(load_layout("paper_matrix_a")).total == pytest.approx(4.4859, abs=5e-4)
    assert layout_complexity(load_layout("paper_matrix_b")).total == pytest.approx(11.1065, abs=5e-4)


def test_cell_map_matches_eq_4_7():
    # Matrix A: obstacles on the top row; the seed prints rows top to bottom.
    occupancy = np.zeros((5, 5), dtype=bool)
    occupancy[0] = True
    cell_map = grid_complexity(occupancy).cell_map
    np.testing.assert_allclose(cell_map[1], [0.8113, 0.9544, 0.9544, 0.9544, 0.8113], atol=1e-4)
    assert cell_map[[0, 2, 3, 4]].sum() == 0


def test_empty_and_full_maps_are_simple():
    assert grid_complexity(np.zeros((4, 4), dtype=bool)).total == 0
    assert grid_complexity(np.ones((4, 4), dtype=bool)).total == 0


def test_every_layout_has_a_complexity():
    for name in ["a320_cell", "shape_changed", "b777_3col", "full_cabin"]:
        result = layout_complexity(load_layout(name))
        assert 0 < result.normalized < 1


def test_cli_prints_json_and_draws_the_map(tmp_path, capsys):
    png = tmp_path / "map.png"
    assert main(["paper_matrix_a", "--json", "--png", str(png)]) == 0
    printed = json.loads(capsys.readouterr().out)
    assert printed["total"] == pytest.approx(4.4859, abs=1e-4)
    assert png.stat().st_size > 1000
