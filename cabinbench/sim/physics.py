"""The world's pymunk side: a layout's space of static walls and bounds and, per episode, dynamic
disc robots driven by velocity commands, with their contact counts.

A :class:`Physics` is built once per world; each :meth:`Physics.reset` puts new robots into it
and leaves it as a new space would be (Chipmunk caches contact state, and numbers its shapes). It
logs every command it is given, so that a copy (``copy.deepcopy``, pickle) rebuilds the space and
replays the episode: Chipmunk's cached contacts (arbiters, their
accumulated impulses) cannot be read or written through pymunk, and a space restored from
pymunk's own pickle leaves them out and drifts from the original within a few contacts.
"""

from __future__ import annotations

import array

import numpy as np
import pymunk
from pymunk._chipmunk import lib as chipmunk

from cabinbench.layouts.model import Layout
from cabinbench.sim.interrupts import shielded

TIME_STEP = 0.1  # seconds of simulated time per env step
PHYSICS_SUBSTEPS = 4  # 1.25 cm of travel per substep: a first contact sinks in at most that far
ROBOT_MASS = 3.5  # kg, an iRobot Create 2
MOTOR_FORCE = 1000.0  # N (and N·m): reaches the commanded velocity within a substep
ROBOT_TYPE, WALL_TYPE, BOUND_TYPE = 1, 2, 3  # pymunk collision types
WALL_CONTACT, ROBOT_CONTACT, BOUND_CONTACT = 0, 1, 2  # the columns of a robot's contact counts


class Physics:
    """The pymunk space of a layout: its walls, built once, and per episode (:meth:`reset`) disc robots
    at given poses and every passage's bounds, built but out of the space (open)."""

    def __init__(self, layout: Layout):
        self.layout = layout
        self.space = space = pymunk.Space()
        space.collision_slop = 0.002  # Chipmunk's default (0.1) is meant for pixels, not metres
        space.add(*[_segment(space, wall, WALL_TYPE) for wall in layout.walls])
        # Chipmunk numbers each shape it is given; robots and bounds are numbered from here in every
        # episode, as in a freshly built space (the numbers order its hash sets).
        self._space = space._space
        self._first_episode_shape = chipmunk.cpSpaceGetShapeIDCounter(self._space)
        self.bound_shapes = [
            [_segment(space, bound, BOUND_TYPE) for bound in passage.bounds] for passage in layout.passages
        ]
        self.bodies, self.motors, self.start_poses = [], [], None
        space.on_collision(ROBOT_TYPE, WALL_TYPE, begin=self._on_wall_contact)
        space.on_collision(ROBOT_TYPE, BOUND_TYPE, begin=self._on_bound_contact)
        space.on_collision(ROBOT_TYPE, ROBOT_TYPE, begin=self._on_robot_contact)

    def reset(self, poses: np.ndarray) -> None:
        """Start an episode with the robots at ``poses`` ((K, 3): x, y, heading), every bound open.

        The last episode's robots and bounds leave the space and new robots enter it. That leaves
        the space as a freshly built one (a building's tens of thousands of wall segments take a
        second to build): Chipmunk drops every cached contact of a shape it removes, its index of
        the walls is what it was before the bounds entered, and the new shapes get the numbers they
        would get in a new space. So an episode does not depend on those before it (tested).
        """
        space = self.space
        leaving = [shape for shapes in self.bound_shapes for shape in shapes if shape.space is not None]
        for body, motor in zip(self.bodies, self.motors):
            leaving += [*body.constraints, *body.shapes, body, motor]
        if leaving:
            space.remove(*leaving)
        chipmunk.cpSpaceSetShapeIDCounter(self._space, self._first_episode_shape)
        self.start_poses = np.array(poses, dtype=np.float64)
        self.commands = array.array("d")  # every drive: robot's motor (vx, vy, turn rate), in order
        self.bound_changes: list[tuple[int, int, bool]] = []  # (steps done, passage, solid)
        self.steps = 0
        radius = self.layout.robot.radius
        self.bodies, self.motors = [], []
        for index, (x, y, heading) in enumerate(self.start_poses.tolist()):
            body = pymunk.Body(ROBOT_MASS, pymunk.moment_for_circle(ROBOT_MASS, 0.0, radius))
            body.position, body.angle = (x, y), heading
            shape = pymunk.Circle(body, radius)
            shape.collision_type, shape.friction, shape.elasticity = ROBOT_TYPE, 0.0, 0.0
            shape.robot_index = index
            # Velocity control through force-limited joints to a kinematic "motor" body (Chipmunk's
            # top-down idiom): contacts always win, so the robot never sinks into a wall. Setting
            # the body's velocity directly each step overrides the contact solver instead.
            motor = pymunk.Body(body_type=pymunk.Body.KINEMATIC)
            motor.position, motor.angle = (x, y), heading
            drive = pymunk.PivotJoint(motor, body, (0, 0), (0, 0))
            steer = pymunk.GearJoint(motor, body, 0.0, 1.0)
            for joint in (drive, steer):
                joint.max_bias, joint.max_force = 0.0, MOTOR_FORCE
            space.add(body, shape, motor, drive, steer)
            self.bodies.append(body)
            self.motors.append(motor)
        # The per-step calls go to Chipmunk's C functions (pymunk._chipmunk, an internal module):
        # pymunk's wrappers (Space.step's bookkeeping for changes made during a step, Vec2d results)
        # cost more than the physics of these small scenes. Nothing is added to or removed from the
        # space during a step and no post-step callback is used, so that bookkeeping is not needed.
        self._bodies = [body._body for body in self.bodies]
        self._motors = [motor._body for motor in self.motors]
        self.contacts = self._no_contacts()

    def set_bound(self, passage: int, solid: bool) -> None:
        """Put a passage's bounds into the space (solid) or take them out."""
        shapes = self.bound_shapes[passage]
        if solid == (shapes[0].space is None):
            (self.space.add if solid else self.space.remove)(*shapes)
            self.bound_changes.append((self.steps, passage, solid))

    def drive(self, robot: int, velocity: tuple[float, float], turn_rate: float) -> None:
        """Command a robot's velocity (m/s, world frame) and turn rate (rad/s) for the next step."""
        chipmunk.cpBodySetVelocity(self._motors[robot], velocity)
        chipmunk.cpBodySetAngularVelocity(self._motors[robot], turn_rate)
        self.commands.extend((velocity[0], velocity[1], turn_rate))

    def step(self) -> list[list[int]]:
        """Advance one env step; returns each robot's contacts during it, indexed by ``*_CONTACT``."""
        for _ in range(PHYSICS_SUBSTEPS):
            chipmunk.cpSpaceStep(self._space, TIME_STEP / PHYSICS_SUBSTEPS)
        self.steps += 1
        contacts, self.contacts = self.contacts, self._no_contacts()
        return contacts

    def poses(self) -> list[tuple[float, float, float]]:
        positions = [chipmunk.cpBodyGetPosition(body) for body in self._bodies]
        return [(p.x, p.y, chipmunk.cpBodyGetAngle(body)) for p, body in zip(positions, self._bodies)]

    def _no_contacts(self) -> list[list[int]]:
        return [[0, 0, 0] for _ in self.bodies]

    def _on_wall_contact(self, arbiter, space, data):
        self.contacts[_robot_of(arbiter)][WALL_CONTACT] += 1

    def _on_bound_contact(self, arbiter, space, data):
        self.contacts[_robot_of(arbiter)][BOUND_CONTACT] += 1

    def _on_robot_contact(self, arbiter, space, data):
        for shape in arbiter.shapes:
            self.contacts[shape.robot_index][ROBOT_CONTACT] += 1

    def __reduce__(self):
        # a copy replays the episode (see the module docstring); bodies moved by hand are not replayed
        if self.start_poses is None:
            return Physics, (self.layout,)
        return _replay, (self.layout, self.start_poses, self.commands, self.bound_changes)


@shielded
def _replay(layout: Layout, start_poses: np.ndarray, commands: array.array, bound_changes: list) -> Physics:
    """A :class:`Physics` that has been given ``commands`` and ``bound_changes`` since its reset to
    ``start_poses``, as the original was: the same space, cached contacts included."""
    physics = Physics(layout)
    physics.reset(start_poses)
    per_step = 3 * len(physics.bodies)
    changes = iter(bound_changes)
    change = next(changes, None)
    for step in range(len(commands) // per_step + 1):
        while change is not None and change[0] == step:
            physics.set_bound(change[1], change[2])
            change = next(changes, None)
        if step * per_step < len(commands):
            for robot in range(len(physics.bodies)):
                at = step * per_step + 3 * robot
                physics.drive(robot, (commands[at], commands[at + 1]), commands[at + 2])
            physics.step()
    return physics


def _segment(space: pymunk.Space, points, collision_type: int) -> pymunk.Segment:
    x0, y0, x1, y1 = points
    segment = pymunk.Segment(space.static_body, (x0, y0), (x1, y1), 0.0)
    segment.collision_type, segment.friction = collision_type, 0.0
    return segment


def _robot_of(arbiter) -> int:
    shape = arbiter.shapes[0] if arbiter.shapes[0].collision_type == ROBOT_TYPE else arbiter.shapes[1]
    return shape.robot_index
