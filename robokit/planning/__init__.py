"""Planning for mobile robots: an occupancy grid built from a lidar, A* over it, and a dynamic-window local
planner that follows the path within the drive's speed and acceleration limits.

Pure numpy, no engine: behaviours use it through :class:`~robokit.planning.navigator.PlanningNavigator`
(``planner = "astar"`` in a navigating behaviour's config). See ``docs/planning.md``.

May import: ``robokit.config`` and ``robokit.msgs`` (no engine, no World).
"""

from robokit.planning.dwa import DwaConfig, DynamicWindow
from robokit.planning.grid import GridConfig, OccupancyGrid
from robokit.planning.navigator import PlanningConfig, PlanningNavigator
from robokit.planning.search import astar, path_length

__all__ = [
    "DwaConfig",
    "DynamicWindow",
    "GridConfig",
    "OccupancyGrid",
    "PlanningConfig",
    "PlanningNavigator",
    "astar",
    "path_length",
]
