"""The classic suite's pages of the leaderboard site: the index (the board, the layouts, "cite this"),
a page per layout (its picture, complexity map, trajectories and replays) and a page per baseline
(what it is, where its records came from, its training curves)."""

from __future__ import annotations

import ast
import json
import shutil
import sys
from pathlib import Path

import numpy as np
import pandas as pd
from PIL import Image

from cabinbench.agents import registered_baselines
from cabinbench.errors import LayoutError
from cabinbench.layouts.complexity import layout_complexity, save_complexity_png
from cabinbench.layouts.fields import RESOLUTION
from cabinbench.layouts.load import available_layouts
from cabinbench.layouts.model import Layout
from cabinbench.layouts.resolve import load_layout
from cabinbench.leaderboard.site_board import Entry, board_table
from cabinbench.leaderboard.site_html import code, escape, figure_html, file_stem, layout_page_name, page
from cabinbench.leaderboard.table import stored_run
from cabinbench.records import safe_name
from cabinbench.sim.render import draw_frame, frame_scale
from cabinbench.sim.world import World

REPLAY_FRAMES = 240  # at most this many positions per robot in a replay: keeps pages small


def docstring(target: str) -> str:
    """The first paragraph of a ``module:Class``'s docstring (else its module's), read from the
    source without importing it (a learned baseline imports torch); empty when not installed."""
    module, _, name = target.partition(":")
    source = module_source(module)
    if source is None:
        return ""
    tree = ast.parse(source.read_text(encoding="utf-8"))
    classes = [node for node in tree.body if isinstance(node, ast.ClassDef) and node.name == name]
    text = (ast.get_docstring(classes[0]) if classes else None) or ast.get_docstring(tree) or ""
    return text.split("\n\n")[0]


def module_source(module: str) -> Path | None:
    """The source file of ``module`` (a package's ``__init__.py``), found by the import system's
    finders as an import would find it, package by package, but importing nothing: so a package
    installed from another folder (setuptools' package-dir, as ``cabinbench.baselines``) is found
    too. None when it is not installed or has no Python source."""
    parts = module.split(".")
    search, spec = None, None
    for depth in range(1, len(parts) + 1):
        name = ".".join(parts[:depth])
        finders = [finder for finder in sys.meta_path if hasattr(finder, "find_spec")]
        spec = next((found for finder in finders if (found := finder.find_spec(name, search))), None)
        if spec is None or (depth < len(parts) and spec.submodule_search_locations is None):
            return None
        search = spec.submodule_search_locations
    origin = Path(spec.origin) if spec.origin else None
    return origin if origin is not None and origin.suffix == ".py" and origin.is_file() else None


def distinct(episodes: pd.DataFrame, column: str) -> list[str]:
    values = episodes[column] if column in episodes else []
    return sorted(
        {json.dumps(value, sort_keys=True) if not isinstance(value, str) else value for value in values}
    )


def baseline_page(baseline: str, entries: list[Entry], images: dict[str, str], command: str, nav: str) -> str:
    target = registered_baselines().get(baseline, baseline if ":" in baseline else "")
    episodes = pd.concat([entry.episodes for entry in entries], ignore_index=True)
    about = docstring(target) if target else ""
    body = [
        f"<h1>{escape(baseline)}</h1>",
        f"<p>{escape(about)}</p>"
        if about
        else '<p class="note">No description: the baseline is not installed here.</p>',
        "<table>",
        f"<tr><th>entry point</th><td><code>{escape(target or 'not installed here')}</code></td></tr>",
        *(
            f"<tr><th>{title}</th><td>{'<br>'.join(map(code, distinct(episodes, column)))}</td></tr>"
            for column, title in (
                ("baseline_config", "config"),
                ("env_config", "env config"),
                ("benchmark_version", "cabinbench version"),
                ("git_commit", "code commit"),
            )
        ),
        "</table>",
        "<h2>Rows</h2>",
        board_table(entries, "../"),
    ]
    if baseline in images:
        body += [
            "<h2>Training curves</h2>",
            f'<figure><img src="../{images[baseline]}" alt="training curves of {escape(baseline)}"></figure>',
        ]
    return page(baseline, "\n".join(body), "../", nav, command)


def replay_data(entry: Entry, layout, scale: int) -> dict | None:
    """The first episode's stored positions for the replay (None when the row has no trajectories:
    a submission)."""
    if entry.is_submission:
        return None
    first = entry.episodes.iloc[0]
    positions = stored_run(first["source"]).episodes[int(first["episode"])]["positions"]
    keep = np.unique(
        np.linspace(0, len(positions) - 1, min(REPLAY_FRAMES, len(positions))).round().astype(int)
    )
    robots = [np.round(positions[keep, robot], 2).ravel().tolist() for robot in range(positions.shape[1])]
    return {
        "origin": list(layout.origin),
        "scale": scale / RESOLUTION,
        "radius": layout.robot.radius,
        "frames": len(keep),
        "robots": robots,
    }


def layout_here(name: str) -> Layout | None:
    """The layout the records call ``name``, as this machine has it; None where no file of that name is
    found (the run read a file outside CABINBENCH_LAYOUT_PATH, or one whose ``name`` is not its file's)."""
    try:
        return load_layout(available_layouts().get(name, name))
    except (OSError, LayoutError):
        return None


def layout_figures(name: str, layout: Layout, entries: list[Entry], out: Path) -> tuple[list[str], str, int]:
    """The layout's picture and complexity map, drawn into ``out/images``: (their HTML, after a note where
    the records were made with another version of the file; the picture's path; the replays' scale)."""
    world = World(layout)
    world.reset(np.random.default_rng(0))  # the start pose is fixed; the generator is unused
    picture = f"images/layout__{file_stem(name)}.png"
    scale = frame_scale(world)
    Image.fromarray(draw_frame(world, scale=scale)).save(out / picture)
    complexity = f"images/complexity__{file_stem(name)}.png"
    save_complexity_png(layout_complexity(layout), str(out / complexity), title=name)
    hashes = {hash_ for entry in entries for hash_ in entry.episodes["layout_hash"]}
    stale = (
        f'<p class="note">The records were made with layout file(s) {", ".join(sorted(hashes))}; the file '
        f"shipped now is {layout.content_hash}.</p>"
        if hashes != {layout.content_hash}
        else ""
    )
    html = [
        stale,
        figure_html(f"../{picture}", f"layout {name}", "the layout (start pose, cells, goals)"),
        figure_html(
            f"../{complexity}", f"complexity of {name}", "navigation complexity per robot-sized cell"
        ),
    ]
    return html, picture, scale


def layout_page(name: str, entries: list[Entry], figures: Path, out: Path, command: str, nav: str) -> str:
    layout = layout_here(name)
    if layout is None:
        fix = (
            f"put its file, {escape(name)}.yaml, in a folder on CABINBENCH_LAYOUT_PATH and build the site "
            "again"
            if safe_name(name) == name
            else "a file cannot be named so: rename the layout "
            f"(<code>name: {escape(safe_name(name))}</code>) and run it again"
        )
        shown = [
            '<p class="note">No layout file of this name is found here, so the page has no picture, '
            f"complexity map or replay: {fix}.</p>"
        ]
    else:
        shown, picture, scale = layout_figures(name, layout, entries, out)
    body = [
        f"<h1>{escape(name)}</h1>",
        *shown,
        "<h2>Rows</h2>",
        board_table(entries, "../"),
        "<h2>Trajectories</h2><p>The first episode of each row (lowest seed)"
        + (". Click a replay to play it.</p>" if layout is not None else ".</p>"),
    ]
    for index, entry in enumerate(entries):
        caption = (
            f"{entry.row['baseline']}, {entry.row['protocol']}, K={entry.row['n_agents']} ({entry.source})"
        )
        figure = figures / f"trajectory__{entry.setting}.png"
        if figure.exists():
            target = f"images/{figure.name}"
            shutil.copyfile(figure, out / target)
            body.append(figure_html(f"../{target}", "trajectory", caption))
        data = replay_data(entry, layout, scale) if layout is not None else None
        if data is not None:
            body.append(
                f'<figure><canvas data-replay="replay{index}" data-picture="../{picture}"></canvas>'
                f"<figcaption>replay: {escape(caption)}</figcaption></figure>"
                f'<script type="application/json" id="replay{index}">'
                f"{json.dumps(data, separators=(',', ':'))}</script>"
            )
    return page(name, "\n".join(body), "../", nav, command)


def index_page(
    suite: str, entries: list[Entry], cite: str, records: int, command: str, nav: str, headline: str = ""
) -> str:
    """The site's first page: the headline table (``headline``, HTML), then the named layouts' board."""
    own = [entry for entry in entries if not entry.is_submission]
    versions = sorted({str(version) for entry in own for version in entry.episodes["benchmark_version"]})
    layouts = sorted(
        {
            (entry.row["layout"], entry.row["complexity_normalized"], entry.row["complexity_total"])
            for entry in entries
        }
    )
    layout_rows = "".join(
        f'<tr><td><a href="{layout_page_name(name)}">{escape(name)}</a></td>'
        f'<td class="num">{normalized:.4f}</td>'
        f'<td class="num">{total:.2f}</td></tr>'
        for name, normalized, total in layouts
    )
    body = [
        f"<h1>cabinbench leaderboard: {escape(suite)}</h1>",
        headline,
        "<h2>Named layouts</h2>",
        f"<p>{len(entries)} rows from {records} episodes; "
        f"benchmark version {escape(', '.join(versions) or 'n/a')}. "
        "Cells are <code>mean ± half-width of the 95% percentile-bootstrap interval</code> over episodes "
        "(hover a cell for the exact bounds; a lone episode has no interval). IQM: interquartile mean. "
        "t90: mean over the episodes that reached 90% coverage [the fraction that did]. "
        "Distinct episodes: episodes with the same outcome count once (a deterministic baseline repeats "
        "one). Policy: a learned baseline's training seed, a row each and one over all seeds. "
        "Complexity: the layout's normalised navigation complexity (the study §4.1). "
        "Click a column title to sort by it. Entries marked as submissions were sent in (see the README); "
        '"verified (M of M replayed)" means every one of its episodes was replayed here and matched; '
        '"unverified (N of M replayed)", that only N were (they matched; the others may not). '
        '<a href="leaderboard.csv">Download the table (CSV)</a>.</p>',
        board_table(entries, "")
        if entries
        else '<p class="note">No records outside a suite: see the suites\' boards (the links above).</p>',
        "<h2>Layouts</h2><table><thead><tr><th>layout</th><th>complexity (normalised)</th>"
        "<th>complexity (total)</th>"
        f"</tr></thead><tbody>{layout_rows}</tbody></table>",
        cite,
    ]
    return page(f"leaderboard: {suite}", "\n".join(body), "", nav, command)
