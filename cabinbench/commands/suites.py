"""``python -m cabinbench.suites``: list the suites, draw a contact sheet of one, or check one
against its manifest (:mod:`cabinbench.layouts.suites` defines them).

    python -m cabinbench.suites [--json] [--png SUITE FILE] [--verify SUITE] [--write-manifests]

``--json`` prints a JSON list, one object per suite; ``--png SUITE FILE`` draws a contact sheet of
the suite's layouts (the first :data:`SHEET_MAX` of a larger suite). Exit status 2 on a user
mistake (an unknown suite, a manifest the generator no longer reproduces), in one line.
"""

from __future__ import annotations

import json
import math

from cabinbench.cli import ArgumentParser, checked_output, output_file, user_errors
from cabinbench.errors import UsageError
from cabinbench.layouts.suites import (
    Suite,
    available_suites,
    get_suite,
    shared_layouts,
    summary,
    verify,
    write_manifest,
)

SHEET_MAX = 100  # layouts on one contact sheet


def table(rows: list[dict]) -> str:
    header = (
        f"{'suite':<16} {'v':>2} {'size':>5}  {'families':<14} {'seats':<28} "
        f"{'complexity':>17} {'normalized':>15}"
    )
    lines = [header, "-" * len(header)]
    for row in rows:
        total, normalized = row["complexity_total"], row["complexity_normalized"]
        lines.append(
            f"{row['name']:<16} {row['version']:>2} {row['size']:>5}  {','.join(row['families']):<14} "
            f"{' '.join(row['seats']):<28} {total[0]:>8.1f}-{total[1]:<8.1f} "
            f"{normalized[0]:>7.4f}-{normalized[1]:.4f}"
        )
    return "\n".join(lines)


def contact_sheet(suite: Suite, path: str) -> None:
    """The suite's layouts (up to :data:`SHEET_MAX`) drawn small in a grid, floor light, obstacles dark."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    names = suite.layout_names[:SHEET_MAX]
    columns = min(5, len(names))
    rows = math.ceil(len(names) / columns)
    figure, axes = plt.subplots(rows, columns, figsize=(3.2 * columns, 1.3 * rows), squeeze=False)
    for axis in axes.flat:
        axis.axis("off")
    for axis, name in zip(axes.flat, names):
        layout = suite.layout(name)
        xmin, ymin, xmax, ymax = layout.extent
        axis.imshow(
            layout.free_raster,
            origin="lower",
            cmap="gray",
            vmin=-0.6,
            vmax=1.1,
            extent=(xmin, xmax, ymin, ymax),
        )
        x, y, _ = layout.start
        axis.plot([x], [y], "o", color="tab:blue", markersize=3)
        seats = layout.parameters.get("seat_blocks")
        label = f"{name}" + (f"  {'-'.join(map(str, seats))}" if seats else "")
        axis.set_title(label, fontsize=7)
    shown = f" (first {len(names)} of {len(suite)})" if len(names) < len(suite) else ""
    figure.suptitle(f"{suite.name} v{suite.version}: {len(suite)} layouts{shown}", fontsize=10)
    figure.tight_layout(rect=(0, 0, 1, 1 - 0.3 / figure.get_figheight()))  # room for the title
    figure.savefig(path, dpi=90)
    plt.close(figure)


@user_errors
def main(argv: list[str] | None = None) -> int:
    parser = ArgumentParser(prog="python -m cabinbench.suites", description="List the suites of layouts.")
    parser.add_argument("--json", action="store_true", help="print a JSON list")
    parser.add_argument(
        "--png", nargs=2, metavar=("SUITE", "FILE"), help="draw a contact sheet of SUITE to FILE.png"
    )
    parser.add_argument("--verify", metavar="SUITE", help="regenerate SUITE and compare it with its manifest")
    parser.add_argument(
        "--write-manifests",
        action="store_true",
        help="regenerate every generated suite's manifest (maintainers)",
    )
    args = parser.parse_args(argv)
    if args.write_manifests:
        for suite in available_suites().values():
            if suite.family:
                print(f"wrote {write_manifest(suite)}")
        shared = shared_layouts()
        if shared:
            raise UsageError(f"suites share layouts (by content hash): {shared[:3]}: change their indices")
        return 0
    if args.verify:
        differing = verify(get_suite(args.verify))
        if differing:
            raise UsageError(
                f"--verify {args.verify}: {len(differing)} layouts differ from the manifest "
                f"(first {differing[0]}): the generator or a family changed; bump the suite's version"
            )
        print(f"{args.verify}: all {len(get_suite(args.verify))} layouts match the manifest")
        return 0
    if args.png:
        suite, path = get_suite(args.png[0]), checked_output("--png", output_file(".png"), args.png[1])
        contact_sheet(suite, str(path))
        print(f"wrote {args.png[1]}")
        return 0
    rows = [summary(suite) for suite in available_suites().values()]
    print(json.dumps(rows, indent=1) if args.json else table(rows))
    return 0
