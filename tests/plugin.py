"""A third-party baseline package, installed the way pip leaves one: its module and a dist-info folder
whose entry_points.txt registers ``spinner = spinner_pkg:Spinner`` in the group ``cabinbench.baselines``.
Put the folder on ``sys.path`` (or ``PYTHONPATH``) and cabinbench finds it with no edit of its own."""

import textwrap
from pathlib import Path


def install_spinner(site: Path) -> Path:
    """Write the package into the folder ``site``; return it."""
    (site / "spinner_pkg").mkdir(parents=True)
    (site / "spinner_pkg" / "__init__.py").write_text(
        textwrap.dedent(
            '''
            import numpy as np
            from cabinbench.agents import Baseline

            class Spinner(Baseline):
                """Turns on the spot."""
                name = "spinner"

                def act(self, observation, info):
                    return np.array([0.0, 1.0])
            '''
        )
    )
    dist_info = site / "spinner_pkg-0.1.dist-info"
    dist_info.mkdir()
    (dist_info / "METADATA").write_text("Metadata-Version: 2.1\nName: spinner-pkg\nVersion: 0.1\n")
    (dist_info / "entry_points.txt").write_text("[cabinbench.baselines]\nspinner = spinner_pkg:Spinner\n")
    return site
