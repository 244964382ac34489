"""``boustrophedon``: the classic coverage planner, planned from the layout and driven through the
env's actions (never by moving the robot).

The modules, in the order a plan is made:

- ``regions``: masks over the layout's robot-centre raster (a cell less its closed bounds, what
  is reachable, what lies near points or a way), A* transits and geodesic distances, in metres.
- ``legs``: ``Leg``, one stretch of a plan and its start condition; ``plan_region``, the raster
  pipeline of :mod:`..coverage_planning` (decomposition → swaths → units → route → path) run on
  one region, sub-cells holding goal markers last.
- ``plan``: ``plan_layout``, one robot's whole plan: cell by cell as the cells open in
  ``sequential``, one sweep of the layout in ``open``; a team's robots get theirs from
  ``convoy``.
- ``work_units`` and ``shares``: for a team of K robots, each stage's region cut into the pieces
  that branch off the aisle, shared out into K contiguous groups, one per rank of a convoy that
  never has to pass or meet head-on (``team_split``).
- ``convoy``: each robot's legs in the team, with the departure gates that keep the convoy order
  (``team_plans``).
- ``baseline``: the ``Boustrophedon`` baseline: takes its robot's legs in ``reset``, follows them
  with a :class:`~cabinbench.baselines.path_following.PathFollower` in ``act``.
- ``demonstrations``: ``record_demonstrations``, the planner as the expert that records
  demonstrations for GAIL.
"""

from cabinbench.baselines.boustrophedon.baseline import Boustrophedon
from cabinbench.baselines.boustrophedon.convoy import plan_team, team_plans
from cabinbench.baselines.boustrophedon.demonstrations import record_demonstrations
from cabinbench.baselines.boustrophedon.legs import Leg, plan_region
from cabinbench.baselines.boustrophedon.plan import plan_layout
from cabinbench.baselines.boustrophedon.regions import cell_region, reachable
from cabinbench.baselines.boustrophedon.shares import TeamSplit, TeamStage, team_split
from cabinbench.baselines.boustrophedon.work_units import team_share, work_units

__all__ = [
    "Boustrophedon",
    "Leg",
    "TeamSplit",
    "TeamStage",
    "cell_region",
    "plan_layout",
    "plan_region",
    "plan_team",
    "reachable",
    "record_demonstrations",
    "team_plans",
    "team_share",
    "team_split",
    "work_units",
]
