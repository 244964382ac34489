"""Waypoint paths in and out of files: CSV, ROS 2 ``nav_msgs/Path`` YAML and GeoJSON.

Every path is in the layout's frame, in metres (the frame of the layout's ROS map, as
``python -m cabinbench.layouts export`` writes it, so ROS's ``map`` frame for a ROS map layout).
A file holds one path per robot; the format is chosen by the file's suffix:

- ``.csv``: rows ``x,y`` or ``x,y,yaw`` (radians), one waypoint a row; an optional header row
  naming those columns; blank lines and lines starting with ``#`` are skipped. One robot.
- ``.yaml`` / ``.yml``: one ``nav_msgs/Path`` message as ``ros2 topic echo --once /plan`` prints it
  (``header.frame_id``, ``poses[].pose.position.x/y``, ``poses[].pose.orientation`` as a
  quaternion), its trailing ``---`` allowed. The frame must be ``map``. One robot.
- ``.geojson`` / ``.json``: a ``LineString`` (a Feature or the bare geometry) for one robot, or a
  ``MultiLineString`` or a ``FeatureCollection`` of LineStrings, one line per robot.
  Coordinates are ``[x, y]`` metres in the layout frame (not longitude and latitude); a third
  coordinate is ignored.

A heading (CSV ``yaw``, the quaternion) is checked but not followed: the path follower turns to
each segment's direction itself. Written files carry at each waypoint the heading of the segment
that leaves it (the last waypoint: of the segment that reaches it), and every coordinate at full
float precision, so a path read back is the path written.

Every problem is a :class:`~cabinbench.errors.BaselineError` in one line that names the file and
the fix.
"""

from __future__ import annotations

import csv
import io
import json
import math
from pathlib import Path

import numpy as np
import yaml

from cabinbench.errors import BaselineError

MIN_WAYPOINTS = 2  # a path is at least one segment
PATH_FRAME = "map"  # the nav_msgs frame that is the layout's frame
FORMATS = {".csv": "csv", ".yaml": "nav_msgs", ".yml": "nav_msgs", ".geojson": "geojson", ".json": "geojson"}
FORMAT_HINT = ".csv (x,y[,yaw]), .yaml (nav_msgs/Path) or .geojson (LineString)"


def path_format(file: str | Path) -> str:
    """``csv``, ``nav_msgs`` or ``geojson``: the format of a path file, from its suffix."""
    suffix = Path(file).suffix.lower()
    if suffix not in FORMATS:
        raise BaselineError(
            f"{file}: unknown path format {suffix or '(no suffix)'!r}; give a {FORMAT_HINT} file"
        )
    return FORMATS[suffix]


# ----------------------------------------------------------------------------------------------- reading


def read_paths(file: str | Path) -> list[np.ndarray]:
    """The paths a file holds, one (N, 2) array of waypoints (x, y) per robot, each checked: at least
    ``MIN_WAYPOINTS`` points, every number finite."""
    reader = {"csv": _read_csv, "nav_msgs": _read_nav_msgs, "geojson": _read_geojson}[path_format(file)]
    try:
        text = Path(file).read_text(encoding="utf-8")
    except (OSError, UnicodeDecodeError) as error:
        reason = error.strerror if isinstance(error, OSError) and error.strerror else type(error).__name__
        raise BaselineError(
            f"{file}: cannot read the path file ({reason}); give a readable {FORMAT_HINT} file"
        ) from None
    return [_checked(file, points, robot) for robot, points in enumerate(reader(file, text))]


def _checked(file, points, robot: int) -> np.ndarray:
    """(N, 2) float waypoints from the rows ``points`` ((N, 2) or (N, 3) with a heading), checked."""
    which = f"path {robot + 1}: " if robot else ""
    try:
        array = np.asarray(points, dtype=float)
    except (TypeError, ValueError):
        raise BaselineError(f"{file}: {which}coordinates must be numbers; give x, y in metres") from None
    if len(array) == 0:
        raise BaselineError(f"{file}: {which}the path has no waypoints; give at least {MIN_WAYPOINTS}")
    bad_rows = ~np.isfinite(array).all(axis=1)
    if bad_rows.any():
        index = int(np.argmax(bad_rows))
        raise BaselineError(
            f"{file}: {which}waypoint {index + 1} is not finite ({array[index].tolist()}); "
            "give finite metres in the layout frame"
        )
    if len(array) < MIN_WAYPOINTS:
        raise BaselineError(
            f"{file}: {which}the path has {len(array)} waypoint; a path needs at least {MIN_WAYPOINTS}"
        )
    return array[:, :2].copy()


def _read_csv(file, text: str) -> list[np.ndarray]:
    rows = [
        (number, row)
        for number, row in enumerate(csv.reader(io.StringIO(text)), start=1)
        if row and any(field.strip() for field in row) and not row[0].lstrip().startswith("#")
    ]
    if rows and not _is_number(rows[0][1][0]):
        number, header = rows.pop(0)
        names = [field.strip().lower() for field in header]
        if names not in (["x", "y"], ["x", "y", "yaw"]):
            raise BaselineError(
                f"{file}: line {number}: header {','.join(header)!r} is not x,y or x,y,yaw; "
                "name the columns x,y[,yaw] (or leave the header out)"
            )
    points = []
    for number, row in rows:
        if len(row) not in (2, 3) or not all(_is_number(field) for field in row):
            raise BaselineError(
                f"{file}: line {number}: {','.join(row)!r} is not x,y or x,y,yaw in numbers; fix that line"
            )
        points.append([float(field) for field in row] + [0.0] * (3 - len(row)))
    return [np.array(points, dtype=float).reshape(-1, 3)]


def _is_number(field: str) -> bool:
    try:
        float(field)
    except ValueError:
        return False
    return True


def _read_nav_msgs(file, text: str) -> list[np.ndarray]:
    try:
        documents = [document for document in yaml.safe_load_all(text) if document is not None]
    except yaml.YAMLError as error:
        where = getattr(error, "problem_mark", None)
        line = f"line {where.line + 1}: " if where is not None else ""
        raise BaselineError(
            f"{file}: {line}not valid YAML; give one nav_msgs/Path as ros2 topic echo prints it"
        ) from None
    if len(documents) != 1:
        raise BaselineError(
            f"{file}: holds {len(documents)} messages; give one nav_msgs/Path (ros2 topic echo --once), "
            "one file per robot"
        )
    message = documents[0]
    if not isinstance(message, dict) or not isinstance(message.get("poses"), list):
        raise BaselineError(
            f"{file}: not a nav_msgs/Path (no poses list); give ros2 topic echo --once output"
        )
    frames = {_frame(message)} | {_frame(stamped) for stamped in message["poses"] if _frame(stamped)}
    if frames != {PATH_FRAME}:
        unknown = sorted(frame for frame in frames if frame != PATH_FRAME) or ["(none)"]
        raise BaselineError(
            f"{file}: frame {unknown[0]!r} is not the layout's frame; give the path in frame "
            f"{PATH_FRAME!r} (transform it first)"
        )
    points = []
    for index, stamped in enumerate(message["poses"], start=1):
        try:
            position, orientation = stamped["pose"]["position"], stamped["pose"]["orientation"]
            x, y = float(position["x"]), float(position["y"])
            qx, qy, qz, qw = (float(orientation[axis]) for axis in "xyzw")
        except (KeyError, TypeError, ValueError):
            raise BaselineError(
                f"{file}: pose {index} lacks pose.position.x/y or pose.orientation x/y/z/w numbers; fix it"
            ) from None
        points.append([x, y, math.atan2(2 * (qw * qz + qx * qy), 1 - 2 * (qy * qy + qz * qz))])
    return [np.array(points, dtype=float).reshape(-1, 3)]


def _frame(message) -> str:
    header = message.get("header") if isinstance(message, dict) else None
    return str(header.get("frame_id") or "") if isinstance(header, dict) else ""


def _read_geojson(file, text: str) -> list[list]:
    try:
        document = json.loads(text)
    except json.JSONDecodeError as error:
        raise BaselineError(
            f"{file}: line {error.lineno}: not valid JSON; give a GeoJSON LineString"
        ) from None
    kind = document.get("type") if isinstance(document, dict) else None
    if kind == "FeatureCollection" and isinstance(document.get("features"), list):
        geometries = [
            feature.get("geometry") if isinstance(feature, dict) else None for feature in document["features"]
        ]
    elif kind == "Feature":
        geometries = [document.get("geometry")]
    else:
        geometries = [document]
    lines = []
    for geometry in geometries:
        kind = geometry.get("type") if isinstance(geometry, dict) else None
        coordinates = geometry.get("coordinates") if isinstance(geometry, dict) else None
        if kind == "LineString" and isinstance(coordinates, list):
            lines.append(coordinates)
        elif kind == "MultiLineString" and isinstance(coordinates, list):
            lines.extend(coordinates)
        else:
            raise BaselineError(
                f"{file}: a {kind or 'non-GeoJSON'} geometry; give a LineString (one robot), or a "
                "MultiLineString or FeatureCollection of LineStrings (one line per robot)"
            )
    if not lines:
        raise BaselineError(f"{file}: holds no LineString; give one line per robot")
    return [_positions(file, line, robot) for robot, line in enumerate(lines)]


def _positions(file, line, robot: int) -> list:
    """A GeoJSON line's positions as [x, y] (a third coordinate, altitude, dropped)."""
    if not all(isinstance(position, list) and len(position) >= 2 for position in line):
        which = f"line {robot + 1}: " if robot else ""
        raise BaselineError(f"{file}: {which}positions must be [x, y] pairs of metres; fix the coordinates")
    return [position[:2] for position in line]


# ----------------------------------------------------------------------------------------------- writing


def headings(points: np.ndarray) -> np.ndarray:
    """The heading (rad) at each waypoint: of the segment that leaves it, the last one's of the segment
    that reaches it (0 for a path of one point)."""
    if len(points) < 2:
        return np.zeros(len(points))
    segments = np.diff(points, axis=0)
    leaving = np.arctan2(segments[:, 1], segments[:, 0])
    return np.append(leaving, leaving[-1])


def write_paths(file: str | Path, paths: list[np.ndarray], name: str = "") -> Path:
    """Write one (N, 2) path per robot to ``file`` in the format of its suffix (CSV and nav_msgs hold
    one path; GeoJSON holds a Feature for one, a FeatureCollection for several). ``name`` labels the
    GeoJSON features. Returns the path written."""
    file = Path(file)
    kind = path_format(file)
    if kind != "geojson" and len(paths) != 1:
        raise BaselineError(f"{file}: a {kind} file holds one path, not {len(paths)}; write a .geojson file")
    writer = {"csv": _csv_text, "nav_msgs": _nav_msgs_text, "geojson": _geojson_text}[kind]
    file.write_text(writer(paths, name), encoding="utf-8")
    return file


def _csv_text(paths: list[np.ndarray], name: str) -> str:
    (points,) = paths
    rows = ["x,y,yaw"] + [
        f"{x!r},{y!r},{yaw!r}" for (x, y), yaw in zip(points.tolist(), headings(points).tolist())
    ]
    return "\n".join(rows) + "\n"


def _nav_msgs_text(paths: list[np.ndarray], name: str) -> str:
    (points,) = paths

    def header() -> dict:  # a new dict each time: YAML would write a shared one as an anchor and aliases
        return {"stamp": {"sec": 0, "nanosec": 0}, "frame_id": PATH_FRAME}

    poses = [
        {
            "header": header(),
            "pose": {
                "position": {"x": x, "y": y, "z": 0.0},
                "orientation": {"x": 0.0, "y": 0.0, "z": math.sin(yaw / 2), "w": math.cos(yaw / 2)},
            },
        }
        for (x, y), yaw in zip(points.tolist(), headings(points).tolist())
    ]
    return yaml.safe_dump({"header": header(), "poses": poses}, sort_keys=False) + "---\n"


def _geojson_text(paths: list[np.ndarray], name: str) -> str:
    features = [
        {
            "type": "Feature",
            "properties": {"name": name, "robot": robot, "frame": "layout, metres"},
            "geometry": {"type": "LineString", "coordinates": points.tolist()},
        }
        for robot, points in enumerate(paths)
    ]
    document = features[0] if len(features) == 1 else {"type": "FeatureCollection", "features": features}
    return json.dumps(document) + "\n"
