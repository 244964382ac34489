"""Path following for a differential-drive robot: waypoint polyline in, velocity commands out.

The follower tracks one segment of the polyline at a time and only moves on to the next one
when its progress along the current segment (the projection of the robot position onto it)
reaches the segment end, so it never cuts or skips a corner. On the current segment it steers
towards a point a short lookahead ahead on the segment line, which corrects the cross-track
error (a robot pushed aside by a wall contact returns to the line rather than heading straight
for the next waypoint). When the heading error is large it turns in place, as the robot must in
pockets that leave it a few centimetres of clearance, and it brakes so as to stop exactly on
every corner that needs such a turn (and on the last waypoint); nearly straight joints are
driven through without stopping.

Actions are normalised to [-1, 1]^2: ``linear * max_speed`` is the forward speed in m/s and
``angular * max_turn_rate`` the turn rate in rad/s, counter-clockwise positive. Everything is
deterministic.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np

from cabinbench.geometry import wrap_angle


class PathFollower:
    """Follows a polyline of waypoints (metres) with rotate-in-place corners and line tracking.

    Parameters:
        waypoints: (N, 2) waypoints in metres.
        max_speed: forward speed (m/s) that a linear command of 1 stands for.
        max_turn_rate: turn rate (rad/s) that an angular command of 1 stands for.
        dt: control period (s); used to stop exactly on a waypoint instead of overshooting it.
        lookahead: distance (m) ahead along the segment line that the robot steers towards.
        align_tolerance: heading error (rad) above which the robot turns in place; also the
            largest turn at a waypoint that is driven through without stopping.
        goal_tolerance: distance (m) to the last waypoint at which the path is done.
        progress_tolerance: how close (m), along the segment, the robot must come to a waypoint
            before it moves on to the next segment.
        deceleration: braking deceleration (m/s^2) used to slow down before stops. A drive that
            takes a moment to follow a new speed command (the physics motor keeps the old speed
            for a substep) overshoots a stop by that moment times the last drop in speed; 1 m/s^2
            keeps the drop small enough that a stop lands within a few millimetres, where 2 m/s^2
            overshot corners by more than a centimetre, into walls 1 cm away.
        heading_gain: proportional gain (1/s) from heading error to turn rate; by default
            0.8 / dt, which removes most of the error in one control period without overshoot.
    """

    def __init__(
        self,
        waypoints: np.ndarray | Sequence[Sequence[float]],
        max_speed: float,
        max_turn_rate: float,
        dt: float,
        lookahead: float = 0.15,
        align_tolerance: float = 0.15,
        goal_tolerance: float = 0.03,
        progress_tolerance: float = 0.002,
        deceleration: float = 1.0,
        heading_gain: float | None = None,
    ):
        self.max_speed = max_speed
        self.max_turn_rate = max_turn_rate
        self.dt = dt
        self.lookahead = lookahead
        self.align_tolerance = align_tolerance
        self.goal_tolerance = goal_tolerance
        self.progress_tolerance = progress_tolerance
        self.deceleration = deceleration
        self.heading_gain = 0.8 / dt if heading_gain is None else heading_gain
        self.set_path(waypoints)

    # ---------------------------------------------------------------- path and progress

    def set_path(self, waypoints: np.ndarray | Sequence[Sequence[float]]) -> None:
        """Follow a new path from its first waypoint, starting from wherever the robot is."""
        self.waypoints = np.asarray(waypoints, dtype=float).reshape(-1, 2)
        if len(self.waypoints) == 0:
            raise ValueError("a path needs at least one waypoint")
        self._stop_distance = self._distances_to_next_stop()
        self.skip_to(0)

    def skip_to(self, index: int) -> None:
        """Make waypoint ``index`` the next target.

        The robot then tracks the path segment that ends there (from waypoint index - 1); for
        index 0 it tracks the line from its own position to the first waypoint.
        """
        if not 0 <= index < len(self.waypoints):
            raise IndexError(f"waypoint index {index} out of range for {len(self.waypoints)} waypoints")
        self._target = index
        # The segment start is the robot position, fixed on the next call to act().
        self._segment_start = self.waypoints[index - 1] if index > 0 else None
        self._done = False

    @property
    def target_index(self) -> int:
        """Index of the waypoint the robot is heading for."""
        return self._target

    @property
    def done(self) -> bool:
        """True once the robot has reached the last waypoint within ``goal_tolerance``."""
        return self._done

    def _distances_to_next_stop(self) -> np.ndarray:
        """For each waypoint, the path length from it to the next waypoint where the robot stops.

        The robot stops at the last waypoint and at every corner that turns by more than
        ``align_tolerance``; it drives through the others at speed.
        """
        count = len(self.waypoints)
        segments = np.diff(self.waypoints, axis=0)
        lengths = np.linalg.norm(segments, axis=1)
        headings = np.arctan2(segments[:, 1], segments[:, 0])
        stop_distance = np.zeros(count)
        for index in range(count - 2, 0, -1):
            turn = abs(wrap_angle(headings[index] - headings[index - 1]))
            if turn <= self.align_tolerance and lengths[index] > 0 and lengths[index - 1] > 0:
                stop_distance[index] = lengths[index] + stop_distance[index + 1]
        return stop_distance

    # ---------------------------------------------------------------- control

    def act(self, pose: Sequence[float]) -> np.ndarray:
        """Normalised [linear, angular] command for the robot at pose (x, y, heading)."""
        if self._done:
            return np.zeros(2)
        position = np.array(pose[:2], dtype=float)
        heading = float(pose[2])
        if self._segment_start is None:
            self._segment_start = position
        last = len(self.waypoints) - 1
        # Move on while the robot has made it to the end of the current segment.
        while True:
            start, end = self._segment_start, self.waypoints[self._target]
            segment = end - start
            length = float(np.hypot(segment[0], segment[1]))
            along = float(np.dot(position - start, segment) / length) if length > 0 else 0.0
            if along < length - self.progress_tolerance:
                break
            if self._target == last:
                if np.hypot(*(end - position)) <= self.goal_tolerance:
                    self._done = True
                    return np.zeros(2)
                break
            self._target += 1
            self._segment_start = self.waypoints[self._target - 1]

        remaining = length - along
        if remaining <= self.progress_tolerance or length == 0.0:
            # Past the end of the last segment but off to the side (pushed): go straight to it.
            offset = end - position
            desired_heading = math.atan2(offset[1], offset[0])
            remaining = float(np.hypot(offset[0], offset[1]))
        else:
            direction = segment / length
            cross_track = direction[0] * (position - start)[1] - direction[1] * (position - start)[0]
            # Aim at the point `lookahead` ahead on the segment line: steers back onto the line.
            segment_heading = math.atan2(direction[1], direction[0])
            desired_heading = segment_heading + math.atan2(-cross_track, self.lookahead)
        heading_error = wrap_angle(desired_heading - heading)
        angular = float(np.clip(self.heading_gain * heading_error, -self.max_turn_rate, self.max_turn_rate))
        if abs(heading_error) > self.align_tolerance:
            return np.array([0.0, angular / self.max_turn_rate])  # turn in place first
        distance_to_stop = remaining + self._stop_distance[self._target]
        speed = min(
            # Slower with a larger heading error, so that driving cannot drift far off the line,
            self.max_speed * (1.0 - abs(heading_error) / self.align_tolerance),
            # braking before a stop,
            math.sqrt(2.0 * self.deceleration * distance_to_stop),
            # and never more than what is left in one period, so as to land on the stop.
            distance_to_stop / self.dt,
        )
        return np.array([speed / self.max_speed, angular / self.max_turn_rate])
