"""``path``: any planner's waypoint path, driven through the env's actions, and planners' paths written out.

- ``formats``: reading and writing paths (CSV ``x,y[,yaw]``, ROS 2 ``nav_msgs/Path`` YAML, GeoJSON
  LineString), one per robot, in the layout's frame.
- ``sweep``: ``planned_sweep``, the static footprint sweep of a plan (planned coverage, length,
  turns, length off the floor or where the robot cannot be), shown beside the executed metrics.
- ``baseline``: ``PathBaseline`` (``--baseline path --config '{"file": "plan.csv"}'``).
- ``export``: ``export_plan``, a planner baseline's plan written to a file in those formats.
"""

from cabinbench.baselines.path.baseline import PathBaseline
from cabinbench.baselines.path.export import export_plan, planned_paths
from cabinbench.baselines.path.formats import read_paths, write_paths
from cabinbench.baselines.path.sweep import planned_sweep

__all__ = ["PathBaseline", "export_plan", "planned_paths", "planned_sweep", "read_paths", "write_paths"]
