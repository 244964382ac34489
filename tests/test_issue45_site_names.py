"""The leaderboard site from records of user layouts and baselines whose names a file name cannot hold
(issue 45, item 7: a layout named ``my/cabin`` broke ``--site`` with "unknown suite")."""

from __future__ import annotations

import re

from cabinbench.commands import leaderboard, run
from cabinbench.leaderboard.site_html import file_stem

CABIN = """\
{name}kind: cabin
cabin: {{width: 3.7, seat_blocks: [3, 3], aisle_width: 0.48, rows: 1, seat_pitch: 0.81, seat_depth: 0.36,
        rows_per_cell: 1, front_clearance: 0.5, rear_clearance: 0.5}}
"""
SHORT = ["--episodes", "1", "--max-steps", "30"]


def test_names_that_differ_only_in_characters_a_file_name_cannot_hold_get_files_of_their_own():
    names = ["my/cabin", "my-cabin", "my:cabin", "my cabin", "my\\cabin", "pkg.module:Class"]
    stems = [file_stem(name) for name in names]
    assert len(set(stems)) == len(names)
    assert all(re.fullmatch(r"[A-Za-z0-9_.-]+", stem) for stem in stems)
    assert file_stem("a320_cell") == "a320_cell"  # a name that is a file name stays as it is


def test_the_site_gives_a_layout_named_my_cabin_its_own_page(tmp_path, monkeypatch, capsys):
    layouts = tmp_path / "layouts"
    layouts.mkdir()
    (layouts / "cabin.yaml").write_text(CABIN.format(name="name: my/cabin\n"))
    (layouts / "my-cabin.yaml").write_text(CABIN.format(name=""))
    monkeypatch.setenv("CABINBENCH_LAYOUT_PATH", str(layouts))
    runs = str(tmp_path / "runs")
    for layout, baseline in [
        (str(layouts / "cabin.yaml"), "boustrophedon"),
        ("my-cabin", "boustrophedon"),
        ("my-cabin", "cabinbench.baselines.random_bounce:RandomBounce"),
    ]:
        assert run.main(["--baseline", baseline, "--layout", layout, *SHORT, "--out", runs]) == 0
    capsys.readouterr()
    assert (
        leaderboard.main(["--runs", runs, "--training", str(tmp_path / "none"), "--out", str(tmp_path)]) == 0
    )
    site = tmp_path / "site"
    assert leaderboard.main(["--runs", runs, "--out", str(tmp_path), "--site", str(site)]) == 0
    stderr = capsys.readouterr().err
    assert "Traceback" not in stderr and "suite" not in stderr

    slash, dash = (site / "layouts" / f"{file_stem(name)}.html" for name in ("my/cabin", "my-cabin"))
    assert slash != dash and slash.is_file() and dash.is_file()
    assert "<h1>my/cabin</h1>" in slash.read_text() and "<h1>my-cabin</h1>" in dash.read_text()
    # the file of my/cabin cannot be found by its name: its page says so and what to do
    assert "rename the layout (<code>name: my-cabin</code>)" in slash.read_text()
    assert "images/layout__my-cabin.png" in dash.read_text()  # found on CABINBENCH_LAYOUT_PATH: drawn
    index = (site / "index.html").read_text()
    for page in (
        slash,
        dash,
        site / "baselines" / f"{file_stem('cabinbench.baselines.random_bounce:RandomBounce')}.html",
    ):
        assert f'href="{page.relative_to(site).as_posix()}"' in index
    for page in site.rglob("*.html"):  # every link and picture of every page is a file of the site
        for target in re.findall(r'(?:href|src|data-picture)="([^"#]+)"', page.read_text()):
            assert (page.parent / target).resolve().is_file(), f"{page}: {target}"
