"""Ctrl-C inside the commands (cabinbench.sim.interrupts): raised where Python can pass it on, so it
is never lost in pymunk's callbacks or destructors and never crashes the process. Each test sends a
real SIGINT from where a key press could land: inside a real pymunk collision handler, inside a
destructor, or in plain Python."""

from __future__ import annotations

import signal
import subprocess
import sys
import time

import numpy as np
import pymunk
import pytest

from cabinbench.layouts.resolve import load_layout
from cabinbench.sim.interrupts import AGAIN_SECONDS, reliable_ctrl_c
from cabinbench.sim.physics import ROBOT_TYPE, WALL_TYPE
from cabinbench.sim.world import World


@pytest.fixture
def python_ctrl_c():
    """Python's own SIGINT handler, as in a terminal (the tests may run as a background job, which
    inherits SIGINT ignored)."""
    previous = signal.signal(signal.SIGINT, signal.default_int_handler)
    yield
    signal.signal(signal.SIGINT, previous)


def ctrl_c_then(handler):
    """A pymunk collision handler that runs ``handler`` and is hit by Ctrl-C as it ends."""

    def begin(arbiter, space, data):
        handler(arbiter, space, data)
        signal.raise_signal(signal.SIGINT)

    return begin


def wait_for_ctrl_c(seconds: float) -> None:
    deadline = time.monotonic() + seconds
    while time.monotonic() < deadline:
        time.sleep(0.001)


def test_a_ctrl_c_inside_a_collision_handler_stops_the_step_it_came_in(python_ctrl_c):
    """Raised by Python's own handler, it would be printed by cffi and lost (the run went on to its
    end and exited 0); here the step it arrived in raises it once that step is complete."""
    world = World(load_layout("a320_cell"))
    world.reset(np.random.default_rng(0))
    physics, collisions = world.physics, []
    physics.space.on_collision(ROBOT_TYPE, WALL_TYPE, begin=ctrl_c_then(physics._on_wall_contact))
    with reliable_ctrl_c():
        with pytest.raises(KeyboardInterrupt):
            for _ in range(2000):  # full speed ahead meets a wall within a few hundred steps
                collisions.append(world.step(np.array([[1.0, 0.0]])).robots[0].collisions)
    assert collisions and sum(collisions) == 0, "the step that met the wall raised it"
    assert physics.steps == len(collisions) + 1, "and ran to its end"


def test_a_ctrl_c_inside_pymunk_outside_the_world_comes_again_once_pymunk_is_done(python_ctrl_c):
    """pymunk's own code (a destructor, a space stepped by hand) is not stopped half way: a body left
    half freed crashes a later garbage collection. The Ctrl-C comes again a moment later."""
    space, body, begun = pymunk.Space(), pymunk.Body(1.0, 1.0), []
    ball, floor = pymunk.Circle(body, 0.5), pymunk.Segment(space.static_body, (-5, -1), (5, -1), 0.1)
    ball.collision_type, floor.collision_type = 1, 2
    space.add(body, ball, floor)
    space.on_collision(1, 2, begin=ctrl_c_then(lambda *_: begun.append(True)))
    body.velocity = (0.0, -10.0)
    with reliable_ctrl_c():
        for _ in range(100):  # a second at 10 m/s: the ball meets the floor within 0.05 s
            space.step(0.01)  # raises nothing: the Ctrl-C came inside pymunk
            if begun:
                break
        with pytest.raises(KeyboardInterrupt):
            wait_for_ctrl_c(100 * AGAIN_SECONDS)


class CtrlCInDestructor:
    def __del__(self):
        signal.raise_signal(signal.SIGINT)


def test_a_ctrl_c_that_a_destructor_swallowed_comes_again(python_ctrl_c):
    with reliable_ctrl_c():
        CtrlCInDestructor()  # dropped at once: Python prints what its destructor raises, and goes on
        with pytest.raises(KeyboardInterrupt):
            wait_for_ctrl_c(100 * AGAIN_SECONDS)


def test_elsewhere_ctrl_c_is_raised_at_once_and_the_handlers_are_restored(python_ctrl_c):
    unraisable_hook = sys.unraisablehook
    with reliable_ctrl_c():
        with pytest.raises(KeyboardInterrupt):
            signal.raise_signal(signal.SIGINT)
    assert signal.getsignal(signal.SIGINT) is signal.default_int_handler
    assert sys.unraisablehook is unraisable_hook


def test_an_ignored_ctrl_c_stays_ignored():
    previous = signal.signal(signal.SIGINT, signal.SIG_IGN)
    try:
        with reliable_ctrl_c():
            assert signal.getsignal(signal.SIGINT) is signal.SIG_IGN
            signal.raise_signal(signal.SIGINT)
        assert signal.getsignal(signal.SIGINT) is signal.SIG_IGN
    finally:
        signal.signal(signal.SIGINT, previous)


# Ctrl-C at 300 moments of building and resetting envs, each caught. Sent by Python's own handler this
# crashed the process within a second (a body left half freed by pymunk's destructor).
CTRL_C_AT_RANDOM_MOMENTS = """
import random, signal
from cabinbench.envs.coverage_env import CoverageEnv
from cabinbench.layouts.resolve import load_layout
from cabinbench.sim.interrupts import reliable_ctrl_c

signal.signal(signal.SIGINT, signal.default_int_handler)
signal.signal(signal.SIGALRM, lambda *_: signal.raise_signal(signal.SIGINT))
random.seed(0)
layout, stopped = load_layout("a320_cell"), 0
with reliable_ctrl_c():
    for _ in range(300):
        signal.setitimer(signal.ITIMER_REAL, random.uniform(0.0002, 0.01))
        try:
            for _ in range(1000):  # a second or more: the Ctrl-C comes within 0.01 s
                CoverageEnv(layout).reset(seed=0)
        except KeyboardInterrupt:
            stopped += 1
print(stopped)
"""


def test_ctrl_c_at_any_moment_of_building_envs_stops_them_and_never_crashes():
    done = subprocess.run(
        [sys.executable, "-c", CTRL_C_AT_RANDOM_MOMENTS], capture_output=True, text=True, timeout=600
    )
    assert done.returncode == 0, done.stderr[-2000:]
    assert done.stdout.split() == ["300"], "each Ctrl-C stopped the envs being built"
    assert "Exception ignored" not in done.stderr
