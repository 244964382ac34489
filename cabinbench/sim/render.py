"""Top-view pictures of a world: floor, seat blocks, covered area, bounds, markers, robots and
their paths (the study's Fig. 5.11 in one frame). Used by the envs' ``rgb_array``/``human``
modes and by ``run --render``.
"""

from __future__ import annotations

import numpy as np
from PIL import Image, ImageDraw

from cabinbench.layouts.fields import RESOLUTION
from cabinbench.sim.lidar import BOUND
from cabinbench.sim.world import World

FLOOR = (238, 228, 208)
OBSTACLE = (96, 112, 140)
COVERED = (232, 128, 118)
GOAL = (255, 255, 255)
EXIT = (40, 170, 70)
ROBOT_COLOURS = [(40, 80, 200), (200, 120, 20), (20, 150, 150), (150, 40, 160), (90, 90, 90), (200, 40, 80)]


def frame_scale(world: World, target: int = 800) -> int:
    rows, cols = world.layout.raster_shape
    return int(np.clip(target // max(rows, cols), 1, 6))


def draw_frame(world: World, trajectories: np.ndarray | None = None, scale: int | None = None) -> np.ndarray:
    """An (H, W, 3) uint8 picture. ``trajectories`` is (T, K, 2) robot positions to draw as paths."""
    scale = scale or frame_scale(world)
    layout = world.layout
    image = np.empty((*layout.raster_shape, 3), dtype=np.uint8)
    image[:] = OBSTACLE
    image[world.floor_mask] = FLOOR
    image[world.pass_count > 0] = COVERED
    picture = Image.fromarray(np.flipud(image)).resize(
        (image.shape[1] * scale, image.shape[0] * scale), Image.Resampling.NEAREST
    )
    draw = ImageDraw.Draw(picture)
    height = image.shape[0]
    x0, y0 = layout.origin

    def to_image(x: float, y: float) -> tuple[float, float]:
        return (x - x0) / RESOLUTION * scale, (height - (y - y0) / RESOLUTION) * scale

    for (x_a, y_a, x_b, y_b), solid, tag in zip(world.segments, world.segment_on, world.segment_tags):
        if solid and tag == BOUND:
            draw.line([to_image(x_a, y_a), to_image(x_b, y_b)], fill=(0, 0, 0), width=max(2, scale))
    marker = max(3, int(0.08 / RESOLUTION * scale))
    goals, exits = world.markers_visible()
    for (x, y), visible in zip(world.circles[: world.n_goals, :2], goals):
        if visible:
            u, v = to_image(x, y)
            draw.rectangle([u - marker, v - marker, u + marker, v + marker], fill=GOAL, outline=(0, 0, 0))
    for (x, y), visible in zip(world.circles[world.n_goals : world.n_goals + world.n_exits, :2], exits):
        if visible:
            u, v = to_image(x, y)
            draw.rectangle([u - marker, v - marker, u + marker, v + marker], fill=EXIT, outline=(0, 0, 0))
    if trajectories is not None and len(trajectories) > 1:
        for robot in range(trajectories.shape[1]):
            colour = ROBOT_COLOURS[robot % len(ROBOT_COLOURS)]
            draw.line(
                [to_image(x, y) for x, y in trajectories[:, robot]], fill=colour, width=max(1, scale // 2)
            )
    radius = layout.robot.radius / RESOLUTION * scale
    for robot, (x, y, heading) in enumerate(world.poses):
        u, v = to_image(x, y)
        colour = ROBOT_COLOURS[robot % len(ROBOT_COLOURS)]
        draw.ellipse([u - radius, v - radius, u + radius, v + radius], fill=colour, outline=(0, 0, 0))
        draw.line(
            [(u, v), (u + radius * np.cos(heading), v - radius * np.sin(heading))],
            fill=(255, 255, 255),
            width=max(1, scale // 2),
        )
    return np.asarray(picture)


class EnvRenderer:
    """An env's ``render()`` and ``close()`` for its ``render_mode``: ``rgb_array`` returns the
    frame, ``human`` shows it in a window and returns None, no mode warns and returns None."""

    def __init__(self, render_mode: str | None):
        self.render_mode = render_mode
        self.viewer: HumanViewer | None = None

    def render(self, world: World, trajectories: np.ndarray | None):
        if self.render_mode is None:
            import gymnasium

            gymnasium.logger.warn(
                "render() called without a render_mode; pass render_mode='rgb_array' or 'human'"
            )
            return None
        frame = draw_frame(world, trajectories)
        if self.render_mode == "rgb_array":
            return frame
        self.viewer = self.viewer or HumanViewer()
        self.viewer.show(frame)
        return None

    def close(self) -> None:
        if self.viewer is not None:
            self.viewer.close()
            self.viewer = None


class HumanViewer:
    """A matplotlib window that shows frames as they come (``render_mode="human"``)."""

    def __init__(self):
        import matplotlib.pyplot as plt

        self.plt = plt
        self.figure = self.image = None

    def show(self, frame: np.ndarray) -> None:
        if self.figure is None:
            self.plt.ion()
            self.figure, axes = self.plt.subplots()
            axes.set_axis_off()
            self.image = axes.imshow(frame)
        else:
            self.image.set_data(frame)
        self.figure.canvas.draw_idle()
        self.figure.canvas.flush_events()

    def close(self) -> None:
        if self.figure is not None:
            self.plt.close(self.figure)
            self.figure = None
