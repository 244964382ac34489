"""Build the benchmark paper: ``python -m cabinbench.paper [--results results] [--out paper/paper.md]``.

Fills ``paper/template.md``'s placeholders from generated material only: ``{{layouts_table}}``
from the layout files (size, cells, areas, complexity), ``{{leaderboard_table}}`` from
``results/leaderboard.md`` and ``{{ablation_table}}`` from ``results/ablation.md`` (both generated from
the run records by ``python -m cabinbench.leaderboard``), and ``{{figures}}`` from ``results/figures/``. Nothing in the
paper's tables is typed by hand; the same inputs give a byte-identical paper.
"""

from __future__ import annotations

import argparse
import os
import sys
from pathlib import Path

from .layout import available_layouts
from .layouts import layout_summary


def layouts_table() -> str:
    lines = [
        "| layout | kind | size (m) | cells | goals | free m² | coverable m² | complexity (total) | complexity (normalized) |",
        "|---|---|---|---|---|---|---|---|---|",
    ]
    for name in available_layouts():
        row = layout_summary(name)
        lines.append(
            f"| `{row['name']}` | {row['kind']} | {row['size_m'][0]:.2f} × {row['size_m'][1]:.2f} | {row['cells']} | "
            f"{row['goals']} | {row['free_area_m2']:.2f} | {row['coverable_area_m2']:.2f} | "
            f"{row['complexity_total']:.4f} | {row['complexity_normalized']:.4f} |"
        )
    return "\n".join(lines)


def generated_table(path: Path) -> str:
    """A generated table file without its title (the paper has its own headings); a note if it is missing."""
    if not path.is_file():
        return f"(no `{path.name}` yet: run `python -m cabinbench.leaderboard`)"
    text = path.read_text(encoding="utf-8")
    return "\n".join(line for line in text.splitlines() if not line.startswith("# ")).strip()


def figures(results: Path, paper_dir: Path) -> str:
    entries = []
    for path in sorted((results / "figures").glob("*.png")):
        relative = Path(os.path.relpath(path, paper_dir)).as_posix()
        entries.append(f"![{path.stem}]({relative})")
    return "\n\n".join(entries) if entries else "(no figures yet)"


def build(template: Path, results: Path, out: Path) -> str:
    text = template.read_text(encoding="utf-8")
    replacements = {
        "{{layouts_table}}": layouts_table(),
        "{{leaderboard_table}}": generated_table(results / "leaderboard.md"),
        "{{ablation_table}}": generated_table(results / "ablation.md"),
        "{{uncovered_table}}": generated_table(results / "uncovered.md"),
        "{{figures}}": figures(results, out.parent),
    }
    for placeholder, value in replacements.items():
        text = text.replace(placeholder, value)
    return text


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(
        prog="python -m cabinbench.paper", description="Build paper/paper.md from the template and results/."
    )
    parser.add_argument("--template", default="paper/template.md")
    parser.add_argument("--results", default="results")
    parser.add_argument("--out", default="paper/paper.md")
    args = parser.parse_args(argv)
    results = Path(args.results)
    if not (results / "leaderboard.md").is_file():
        print(
            f"{results / 'leaderboard.md'} is missing: run `python -m cabinbench.leaderboard` first",
            file=sys.stderr,
        )
        return 1
    out = Path(args.out)
    out.write_text(build(Path(args.template), results, out), encoding="utf-8")
    print(f"wrote {out}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
