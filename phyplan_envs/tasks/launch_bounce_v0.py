"""LaunchBounce-v0, superseded by LaunchBounce-v1 (:mod:`phyplan_envs.tasks.launch_bounce`) and kept registered and
reproducible.

Frozen: this file changes only if the v0 outcomes would otherwise change. The versions differ in the timestep
alone; the task, its design notes and its facts are :mod:`phyplan_envs.tasks.launch_bounce`'s.
"""
from __future__ import annotations

from .launch_bounce import LaunchBounceEnv

TIMESTEP_V0 = 0.0005   # s


class LaunchBounceEnvV0(LaunchBounceEnv):
    """``PhyPlan/LaunchBounce-v0``: LaunchBounce (:class:`phyplan_envs.tasks.launch_bounce.LaunchBounceEnv`, whose
    docstring is the spec: scene, context, reward) at a 0.5 ms timestep, the end rule every 5 ms.

    ==================  =====================  ====  ===========================================================
    action              bounds                 unit  meaning
    ==================  =====================  ====  ===========================================================
    ``phi``             [0, pi/2]              rad   plane of the pendulum's swing (direction the ball is hit)
    ``theta``           [pi/4, pi/2]           rad   release angle of the pendulum from vertical
    ``wedge_distance``  [0.2, 1.0]             m     distance of the wedge's axis from the pedestal
    ``wedge_angle``     [0, pi/2]              rad   direction of the wedge's axis from the pedestal (from +x)
    ``wedge_yaw``       [-pi, pi]              rad   yaw of the wedge: its incline falls towards ``wedge_yaw``
    ==================  =====================  ====  ===========================================================

    State observation (float32, m): ``goal_x, goal_y, object_x, object_y, object_z, pivot_height`` (as v1).

    At this timestep the landings of bouncing actions move by 5.04 mm at p90 when the timestep halves (over the 5 mm
    a task is held to); v1 steps at 0.25 ms.

    Version History:

    * v0: first release (kept registered and reproducible; superseded by v1, whose timestep is 0.25 ms).
    """

    timestep = TIMESTEP_V0
    chunk = 10
