"""Every user mistake, in every command, is one line on stderr naming the argument or file and the
fix, exit status 2, no traceback, and nothing written. The commands run as real subprocesses, all
started at once (each is mostly the interpreter's start-up)."""

import os
import subprocess
import sys
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

import numpy as np
import pytest
from PIL import Image

ROOT = Path(__file__).resolve().parents[1]
RUN = ["run", "--baseline", "random_bounce", "--layout", "a320_cell", "--episodes", "1", "--max-steps", "10"]

UNWRITABLE = "/sys/kernel"  # a folder nobody may create a file in, root included (chmod does not stop root)
NOWHERE = "/proc/cabinbench"  # under a folder nobody may create a folder in
SUITE_RUN = ["run", "--baseline", "random_bounce", "--suite", "classic", "--episodes-per-layout", "1"]
CANNOT_WRITE = "give a folder you can write in"
# Every output path, checked before the work starts: an unwritable folder, a file or folder in the way,
# a missing folder (issue 45). Nothing is run or written first: a submission is not lost after the run.
OUTPUT_CASES = {
    "run: --out in an unwritable folder": (
        [*RUN, "--out", f"{UNWRITABLE}/runs"],
        ["argument --out", CANNOT_WRITE],
    ),
    "run: --out under /proc": (
        [*RUN, "--out", f"{NOWHERE}/runs"],
        ["argument --out", "cannot write in /proc"],
    ),
    "run: --render in an unwritable folder": (
        [*RUN, "--render", f"{UNWRITABLE}/first.png"],
        ["argument --render", f"cannot write in {UNWRITABLE}", CANNOT_WRITE],
    ),
    "run: --render is a folder": ([*RUN, "--render", "picture.png"], ["argument --render", "is a folder"]),
    "run: --submission in an unwritable folder": (
        [*SUITE_RUN, "--submission", f"{UNWRITABLE}/s.json"],
        ["argument --submission", f"cannot write in {UNWRITABLE}"],
    ),
    "run: --submission is a folder": (
        [*SUITE_RUN, "--submission", "submission.json"],
        ["argument --submission", "'submission.json' is a folder: give a file name"],
    ),
    "run: --submission into a missing folder": (
        [*SUITE_RUN, "--submission", "missing/s.json"],
        ["argument --submission", "no folder missing; create it first"],
    ),
    "run: --layouts beyond the suite": (
        [*SUITE_RUN, "--layouts", "1000"],
        ["--layouts 1000: suite classic has 7 layouts; give at most 7"],
    ),
    "leaderboard: --out in an unwritable folder": (
        ["leaderboard", "--out", f"{UNWRITABLE}/results"],
        ["--out:", f"cannot write in {UNWRITABLE}"],
    ),
    "leaderboard: --site in an unwritable folder": (
        ["leaderboard", "--site", f"{UNWRITABLE}/site"],
        ["argument --site", f"cannot write in {UNWRITABLE}"],
    ),
    "leaderboard: --site is a file": (
        ["leaderboard", "--site", "file.txt"],
        ["argument --site", "file.txt is a file"],
    ),
    "leaderboard: --add of a folder": (
        ["leaderboard", "--add", "submission.json"],
        ["submission.json: is a folder; give the submission file"],
    ),
    "leaderboard: --verify of a folder": (
        ["leaderboard", "--verify", "submission.json"],
        ["submission.json: is a folder; give the submission file"],
    ),
    "leaderboard: --add of a submission with NaN": (
        ["leaderboard", "--add", "nan.json"],
        ["nan.json: NaN is not a JSON number", "must be finite"],
    ),
    "leaderboard: --verify of a submission with NaN": (
        ["leaderboard", "--verify", "nan.json"],
        ["nan.json: NaN is not a JSON number"],
    ),
    "leaderboard: --episodes without --verify": (
        ["leaderboard", "--episodes", "3"],
        ["--episodes goes with --verify"],
    ),
    "layouts: export into an unwritable folder": (
        ["layouts", "export", "a320_cell", f"{UNWRITABLE}/maps"],
        ["argument out_dir", f"cannot write in {UNWRITABLE}"],
    ),
    "layouts: export under /proc": (
        ["layouts", "export", "a320_cell", f"{NOWHERE}/maps"],
        ["argument out_dir", "cannot write in /proc"],
    ),
    "layouts: export at a resolution too fine for the machine": (
        ["layouts", "export", "a320_cell", "maps", "--resolution", "0.00001"],
        [
            "--resolution 1e-05: a320_cell",
            "px and needs about",
            "GiB allowed on this machine",
            "coarser --resolution",
        ],
    ),
    "complexity: --png in an unwritable folder": (
        ["complexity", "a320_cell", "--png", f"{UNWRITABLE}/map.png"],
        ["argument --png", f"cannot write in {UNWRITABLE}"],
    ),
    "suites: --png in an unwritable folder": (
        ["suites", "--png", "classic", f"{UNWRITABLE}/sheet.png"],
        ["--png:", f"cannot write in {UNWRITABLE}"],
    ),
    "suites: --png into a missing folder": (
        ["suites", "--png", "classic", "missing/sheet.png"],
        ["--png: 'missing/sheet.png': no folder missing"],
    ),
    "suites: --png is a folder": (["suites", "--png", "classic", "picture.png"], ["--png:", "is a folder"]),
    "paper: --out in an unwritable folder": (
        ["paper", "--out", f"{UNWRITABLE}/paper.md"],
        ["argument --out", f"cannot write in {UNWRITABLE}"],
    ),
    "paper: --out into a missing folder": (
        ["paper", "--out", "missing/paper.md"],
        ["argument --out", "no folder missing"],
    ),
    "paper: a placeholder nothing fills": (
        [
            "paper",
            "--results",
            str(ROOT / "results"),
            "--template",
            "unknown_placeholder.md",
            "--out",
            "paper.md",
        ],
        [
            "--template: unknown_placeholder.md has the placeholder(s) {{results_table}}",
            "which nothing fills; use {{abstract}}",
        ],
    ),
    "building_maps: into an unwritable folder": (
        ["building_maps", f"{UNWRITABLE}/maps"],
        ["argument out", f"cannot write in {UNWRITABLE}"],
    ),
    "building_maps: under a file": (
        ["building_maps", "file.txt/maps"],
        ["argument out", "file.txt is a file"],
    ),
}

# name: (argv after `python -m cabinbench.`, fragments the one stderr line must hold)
CASES = {
    "run: unknown baseline": (
        ["run", "--baseline", "nope", "--layout", "a320_cell"],
        ["unknown baseline 'nope'", "random_bounce", "package.module:ClassName"],
    ),
    "run: unknown layout": (
        ["run", "--baseline", "random_bounce", "--layout", "nope"],
        ["nope: field '<name>': unknown layout", "a320_cell", "Fix:"],
    ),
    "run: broken layout": (
        ["run", "--baseline", "random_bounce", "--layout", "bad.yaml"],
        ["bad.yaml: field 'kind'", "Fix: set kind to one of cabin, grid, polygons"],
    ),
    "run: layout not UTF-8": (
        ["run", "--baseline", "random_bounce", "--layout", "latin.yaml"],
        ["latin.yaml: field '<file>': not UTF-8 text (line 2)", "Fix: save the file as UTF-8"],
    ),
    "run: layout is a folder": (
        ["run", "--baseline", "random_bounce", "--layout", "folder.yaml"],
        ["folder.yaml: field '<file>': is a folder", "Fix:"],
    ),
    "run: negative seed": ([*RUN, "--seed", "-5"], ["argument --seed", "'-5' is not a whole number >= 0"]),
    "run: no episodes": ([*RUN, "--episodes", "0"], ["argument --episodes", ">= 1"]),
    "run: too many robots": ([*RUN, "--agents", "60"], ["--agents", "room for only", "use fewer agents"]),
    "run: unknown reward": ([*RUN, "--reward", "nope"], ["argument --reward", "paper", "coverage"]),
    "run: config not JSON": ([*RUN, "--config", "{"], ["argument --config", "not valid JSON", "min_turn"]),
    "run: config not an object": ([*RUN, "--config", "[1]"], ["argument --config", "not a JSON object"]),
    "run: setting random_bounce does not take": (
        [*RUN, "--config", '{"speed": 1}'],
        ["--config", "'random_bounce' does not take speed", "it takes min_turn"],
    ),
    "run: setting boustrophedon does not take": (
        [*RUN[:2], "boustrophedon", *RUN[3:], "--config", '{"speed": 1}'],
        ["--config", "'boustrophedon' does not take speed", "no settings"],
    ),
    "run: a setting of the wrong kind": (
        [*RUN, "--config", '{"min_turn": "wide"}'],
        ["--baseline random_bounce", "min_turn must be an angle in radians from 0 to pi, got 'wide'"],
    ),
    "run: stochastic not true or false": (
        [*RUN[:2], "ppo", *RUN[3:], "--config", '{"stochastic": "no"}'],
        ["--baseline ppo", "stochastic must be true or false, got 'no'"],
    ),
    "run: missing checkpoint": (
        [*RUN[:2], "ppo", *RUN[3:], "--config", '{"checkpoint": "nope.pt"}'],
        ["--baseline ppo", "nope.pt: policy file not found", "--ship"],
    ),
    "run: policy file not a torch file": (
        [*RUN[:2], "ppo", *RUN[3:], "--config", '{"checkpoint": "file.txt"}'],
        ["file.txt: cannot read the policy file", "weights_only=True"],
    ),
    "run: --out is a file": ([*RUN, "--out", "file.txt"], ["argument --out", "file.txt is a file", "folder"]),
    "run: --render into a missing folder": (
        [*RUN, "--render", "missing/first.png"],
        ["argument --render", "no folder missing", "create it first"],
    ),
    "run: --render of another format": (
        [*RUN, "--render", "first.jpg"],
        ["argument --render", ".png or .gif"],
    ),
    "run: --address of the local executor": (
        [*RUN, "--address", "auto"],
        ["--address", "only --executor ray runs on a cluster"],
    ),
    "run: --address where no cluster runs": (
        [*RUN, "--executor", "ray", "--address", "127.0.0.1:9"],
        ["--address 127.0.0.1:9: no Ray cluster to join there", "ray start --head"],
    ),
    "run: --workers with Ray": (
        [*RUN, "--executor", "ray", "--workers", "2"],
        ["--workers", "the local executor's"],
    ),
    **{
        f"run: ROS map {problem}": (
            ["run", "--baseline", "random_bounce", "--layout", f"{name}.yaml"],
            [f"{name}.yaml: field '{field}'", *fragments, "Fix:"],
        )
        for name, (problem, field, fragments) in {
            "map_missing": ("image missing", "image", ["nope.pgm not found"]),
            "map_text": ("image not an image", "image", ["is not an image"]),
            "map_colour": ("image in colour", "image", ["not an 8-bit grey image (mode RGB)"]),
            "map_deep": ("image of 16 bits", "image", ["not an 8-bit grey image (mode I)"]),
            "map_truncated": ("image truncated", "image", ["is damaged"]),
            "map_resolution": ("resolution 0", "resolution", ["must be positive"]),
            "map_threshold": ("threshold above 1", "occupied_thresh", ["must be in [0, 1]"]),
            "map_order": ("free above occupied", "free_thresh", ["not below occupied_thresh"]),
            "map_no_free": ("without free pixels", "image", ["has no free pixel"]),
            "map_start": ("start in a wall", "start", ["inside an obstacle"]),
            "map_huge": (
                "too large for the machine",
                "image",
                ["13000 x 13000 px", "GiB allowed on this machine"],
            ),
        }.items()
    },
    "complexity: ROS map image missing": (["complexity", "map_missing.yaml"], ["field 'image'", "not found"]),
    "layouts: export of an unknown layout": (
        ["layouts", "export", "nope", "out"],
        ["unknown layout", "Fix:"],
    ),
    "layouts: export into a file": (["layouts", "export", "a320_cell", "file.txt"], ["file.txt is a file"]),
    "layouts: export at resolution 0": (
        ["layouts", "export", "a320_cell", "out", "--resolution", "0"],
        ["argument --resolution", "'0' is not a number > 0"],
    ),
    "complexity: a number YAML reads as text": (
        ["complexity", "exponent.yaml"],
        ["exponent.yaml: field 'grid.cell_size'", "got '1e6'", "YAML reads 1e6 as text", "1.0e+6"],
    ),
    "complexity: broken layout": (["complexity", "bad.yaml"], ["bad.yaml: field 'kind'", "Fix:"]),
    "complexity: layout not UTF-8": (["complexity", "latin.yaml"], ["latin.yaml", "not UTF-8", "Fix:"]),
    "complexity: layout is a folder": (["complexity", "folder.yaml"], ["folder.yaml", "is a folder", "Fix:"]),
    "complexity: unknown layout": (["complexity", "nope"], ["unknown layout", "a320_cell"]),
    "complexity: --png of another format": (
        ["complexity", "a320_cell", "--png", "map.txt"],
        ["argument --png", "map.txt", ".png"],
    ),
    "complexity: --png into a missing folder": (
        ["complexity", "a320_cell", "--png", "missing/map.png"],
        ["argument --png", "no folder missing"],
    ),
    "layouts: a bad file in the layout path": (
        ["layouts"],
        ["layouts/bad.yaml: field 'kind'", "Fix:"],
    ),
    "layouts: unknown option": (["layouts", "--bogus"], ["unrecognized arguments: --bogus", "--help"]),
    "run: unknown suite": (
        ["run", "--baseline", "random_bounce", "--suite", "nope"],
        ["nope: field '<suite>': unknown suite", "cabin-v1-test"],
    ),
    "run: suite layout out of range": (
        [*RUN[:3], "--layout", "cabin-v1-test/0100"],
        ["cabin-v1-test/0100", "not a layout of suite cabin-v1-test", "cabin-v1-test/0099"],
    ),
    "run: --episodes with --suite": (
        ["run", "--baseline", "random_bounce", "--suite", "cabin-v1-test", "--episodes", "2"],
        ["--episodes goes with --layout", "--episodes-per-layout"],
    ),
    "run: --layout and --suite": (
        [*RUN, "--suite", "cabin-v1-test"],
        ["argument --suite", "not allowed with argument --layout"],
    ),
    "run: a submission with --max-steps": (
        [
            "run",
            "--baseline",
            "random_bounce",
            "--suite",
            "classic",
            "--max-steps",
            "9",
            "--submission",
            "s.json",
        ],
        ["--max-steps: a submission follows the suite's protocol", "drop --max-steps"],
    ),
    "run: a submission of some layouts": (
        [
            "run",
            "--baseline",
            "random_bounce",
            "--suite",
            "classic",
            "--layouts",
            "2",
            "--submission",
            "s.json",
        ],
        ["--layouts: a submission follows the suite's protocol", "every layout"],
    ),
    "suites: unknown suite": (["suites", "--png", "nope", "sheet.png"], ["unknown suite", "classic"]),
    "suites: --png of another format": (["suites", "--png", "classic", "sheet.txt"], ["--png", ".png"]),
    "leaderboard: no such folder": (["leaderboard", "--runs", "nope"], ["--runs", "no folder nope"]),
    "leaderboard: no records": (["leaderboard", "--runs", "layouts"], ["--runs", "no records in layouts"]),
    "leaderboard: --out is a file": (["leaderboard", "--out", "file.txt"], ["--out: file.txt is a file"]),
    "paper: no leaderboard": (
        ["paper", "--results", "layouts", "--out", "paper.md"],
        ["--results", "leaderboard.md is missing"],
    ),
    "paper: no template": (
        ["paper", "--results", str(ROOT / "results"), "--template", "nope.md", "--out", "paper.md"],
        ["--template", "no file nope.md"],
    ),
    "paper: unknown option": (["paper", "--bogus"], ["unrecognized arguments: --bogus"]),
    "paper: no folder for the default --out": (
        ["paper", "--results", str(ROOT / "results"), "--template", str(ROOT / "paper" / "template.md")],
        ["--out: 'paper/paper.md': no folder paper; create it first"],
    ),
    "bench: bad step count": (["bench", "--steps", "0"], ["argument --steps", ">= 1"]),
    "train: unknown baseline": (["train", "--baseline", "nope"], ["unknown baseline 'nope'", "ppo_gail"]),
    "train: a baseline that does not learn": (
        ["train", "--baseline", "random_bounce"],
        ["'random_bounce' does not learn", "trainable baselines: ", "ppo_gail"],
    ),
    "train: unknown option": (["train", "--baseline", "ppo", "--bogus"], ["unrecognized arguments: --bogus"]),
    "train: --suite for the team": (
        ["train", "--baseline", "ppo_gail_team", "--suite", "cabin-v1-train"],
        ["--suite trains ppo_gail, ppo, ppo_icm, ppo_gail_only", "on a suite instead of --layout"],
    ),
    "train: unknown layout": (
        ["train", "--baseline", "ppo", "--layout", "nope", "--iterations", "1"],
        ["unknown layout", "a320_cell"],
    ),
    "train: --seed and --seeds": (
        ["train", "--baseline", "ppo", "--seed", "1", "--seeds", "0", "1"],
        ["--seed", "give the seeds with --seeds alone"],
    ),
    "train: several baselines without --seeds": (
        ["train", "--baseline", "ppo", "ppo_icm"],
        ["several baselines train as one sweep", "--seeds"],
    ),
    "train: an untrainable baseline in a sweep": (
        ["train", "--baseline", "ppo", "boustrophedon", "--seeds", "0"],
        ["'boustrophedon' does not learn"],
    ),
    "building_maps: unknown option": (["building_maps", "--bogus"], ["unrecognized arguments: --bogus"]),
    "building_maps: into a file": (["building_maps", "file.txt"], ["argument out", "file.txt is a file"]),
    "differences: --out of another format": (
        ["baselines.ppo_gail.differences", "--out", "table.txt"],
        ["argument --out", "ending in .md"],
    ),
    "differences: --out into a missing folder": (
        ["baselines.ppo_gail.differences", "--out", "missing/table.md"],
        ["argument --out", "no folder missing"],
    ),
    "differences: no shipped config": (
        ["baselines.ppo_gail.differences", "--out", "table.md", "--shipped-config", "missing.json"],
        ["argument --shipped-config", "no file missing.json"],
    ),
    "train: --demo-layouts without --suite": (
        ["train", "--baseline", "ppo_gail", "--layout", "a320_cell", "--demo-layouts", "3"],
        ["--demo-layouts goes with --suite"],
    ),
    "train: --run-dir is a file": (
        ["train", "--baseline", "ppo", "--run-dir", "file.txt"],
        ["argument --run-dir", "file.txt is a file"],
    ),
    "train: --init-policy not found": (
        ["train", "--baseline", "ppo_gail_team", "--init-policy", "nope.pt", "--iterations", "1"],
        ["nope.pt: policy file not found"],
    ),
    "train: --executor without --seeds": (
        ["train", "--baseline", "ppo", "--executor", "ray"],
        ["--executor and --address run the seeds of --seeds"],
    ),
    **OUTPUT_CASES,
}


def write_inputs(folder: Path) -> None:
    (folder / "bad.yaml").write_text("kind: maze\n")
    (folder / "exponent.yaml").write_text("kind: grid\ngrid:\n  cell_size: 1e6\n  map: |\n    ..S..\n")
    (folder / "latin.yaml").write_bytes(b"kind: grid\n# caf\xe9\n")
    (folder / "folder.yaml").mkdir()
    (folder / "file.txt").write_text("not a folder\n")
    (folder / "layouts").mkdir()
    (folder / "layouts" / "bad.yaml").write_text("kind: maze\n")
    (folder / "layouts" / "room.yaml").write_text((ROOT / "layouts" / "paper_matrix_a.yaml").read_text())
    write_ros_maps(folder)
    (folder / "picture.png").mkdir()
    (folder / "submission.json").mkdir()
    (folder / "nan.json").write_text(
        '{"format": "cabinbench-submission/1", "records": [{"coverage": NaN}]}\n'
    )
    (folder / "unknown_placeholder.md").write_text("# Paper\n\n{{leaderboard_table}}\n\n{{results_table}}\n")


def write_ros_maps(folder: Path) -> None:
    """One broken ROS map per bad input of a map (issue 19), each beside a good image."""
    room = np.full((40, 40), 254, np.uint8)
    room[:2], room[-2:], room[:, :2], room[:, -2:] = 0, 0, 0, 0
    Image.fromarray(room).save(folder / "room.pgm")
    Image.fromarray(np.stack([room] * 3, axis=-1)).save(folder / "colour.png")
    (folder / "deep.pgm").write_bytes(b"P5\n40 40\n65535\n" + bytes(40 * 40 * 2))
    (folder / "truncated.pgm").write_bytes(b"P5\n40 40\n255\n" + bytes(100))
    Image.fromarray(np.zeros((40, 40), np.uint8)).save(folder / "black.pgm")
    (folder / "huge.pgm").write_bytes(b"P5\n13000 13000\n255\n" + bytes(10))  # 1 m a pixel: 13 km a side
    plain = "resolution: 0.05\norigin: [0.0, 0.0, 0.0]\n"
    maps = {
        "map_missing": "image: nope.pgm\n" + plain,
        "map_text": "image: file.txt\n" + plain,
        "map_colour": "image: colour.png\n" + plain,
        "map_deep": "image: deep.pgm\n" + plain,
        "map_truncated": "image: truncated.pgm\n" + plain,
        "map_resolution": "image: room.pgm\nresolution: 0\norigin: [0.0, 0.0, 0.0]\n",
        "map_threshold": "image: room.pgm\noccupied_thresh: 1.5\n" + plain,
        "map_order": "image: room.pgm\nfree_thresh: 0.7\noccupied_thresh: 0.65\n" + plain,
        "map_no_free": "image: black.pgm\n" + plain,
        "map_huge": "image: huge.pgm\nresolution: 1.0\norigin: [0.0, 0.0, 0.0]\n",
        "map_start": "kind: occupancy\nstart: [0.02, 1.0]\noccupancy:\n  image: room.pgm\n"
        "  resolution: 0.05\n  origin: [0.0, 0.0, 0.0]\n",
    }
    for name, text in maps.items():
        (folder / f"{name}.yaml").write_text(text)


@pytest.fixture(scope="module")
def outcomes(tmp_path_factory):
    """name → (exit status, stdout, stderr) of every case, run in one folder holding its inputs."""
    folder = tmp_path_factory.mktemp("user_errors")
    write_inputs(folder)
    environment = {**os.environ, "CABINBENCH_LAYOUT_PATH": str(folder / "layouts")}

    def run(argv):
        result = subprocess.run(
            [sys.executable, "-m", f"cabinbench.{argv[0]}", *argv[1:]],
            cwd=folder,
            env=environment,
            capture_output=True,
            text=True,
            timeout=300,
        )
        return result.returncode, result.stdout, result.stderr

    before = sorted(path.relative_to(folder) for path in folder.rglob("*"))
    with ThreadPoolExecutor(max_workers=os.cpu_count() or 2) as pool:
        results = dict(zip(CASES, pool.map(run, [argv for argv, _ in CASES.values()])))
    after = sorted(path.relative_to(folder) for path in folder.rglob("*"))
    return results, before, after, folder


@pytest.mark.parametrize("name", list(CASES))
def test_user_error_is_one_line_exit_2(outcomes, name):
    results, *_ = outcomes
    status, _, stderr = results[name]
    assert "Traceback" not in stderr
    assert status == 2, stderr
    lines = [line for line in stderr.splitlines() if line.strip()]
    assert len(lines) == 1, stderr
    for fragment in CASES[name][1]:
        assert fragment in lines[0]


def test_user_errors_write_nothing(outcomes):
    *_, before, after, _ = outcomes
    assert after == before


def test_a_bad_layout_file_loses_none_of_the_others(outcomes):
    results, *_ = outcomes
    _, stdout, _ = results["layouts: a bad file in the layout path"]
    listed = [line.split()[0] for line in stdout.splitlines()[2:]]
    assert "room" in listed and "a320_cell" in listed and "bad" not in listed
