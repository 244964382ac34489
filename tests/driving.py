"""A tiny waypoint driver for tests: turn on the spot towards the next point, then drive."""

import math

import numpy as np

from cabinbench.geometry import wrap_angle


def action_towards(pose, target, tolerance=0.01):
    """(action, arrived) for a unicycle at ``pose`` heading for ``target``."""
    x, y, heading = pose
    dx, dy = target[0] - x, target[1] - y
    distance = math.hypot(dx, dy)
    if distance < tolerance:
        return np.zeros(2), True
    error = wrap_angle(math.atan2(dy, dx) - heading)
    turn = float(np.clip(error / (2.0 * 0.1), -1, 1))  # reach the heading in about one step
    if abs(error) > 0.05:
        return np.array([0.0, turn]), False
    return np.array([float(np.clip(distance / 0.05, 0.1, 1.0)), turn]), False


def drive(env, waypoints, max_steps=5000):
    """Drive a reset single-robot env through ``waypoints``; return the last (info, terminated)."""
    info = {"pose": env.unwrapped.world.poses[0]}
    terminated = truncated = False
    for target in waypoints:
        for _ in range(max_steps):
            action, arrived = action_towards(info["pose"], target)
            if arrived:
                break
            _, _, terminated, truncated, info = env.step(action)
            if terminated or truncated:
                return info, terminated
    return info, terminated
