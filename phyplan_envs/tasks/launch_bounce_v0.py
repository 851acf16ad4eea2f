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

    {actions}

    State observation (float32, m): ``goal_x, goal_y, object_x, object_y, object_z, pivot_height`` (as v1).

    At this timestep the landings of bouncing actions have not converged in the timestep (docs/composition.md,
    *Certificates*); v1 steps at 0.25 ms.

    Version History:

    * v0: first release (kept registered and reproducible; superseded by v1, whose timestep is 0.25 ms).
    """

    timestep = TIMESTEP_V0
    chunk = 10


def _action_table(doc: str) -> str:
    """The action table of a task docstring (from its first ``====`` rule to its last)."""
    lines = doc.splitlines()
    rules = [i for i, line in enumerate(lines) if line.strip().startswith("====")]
    return "\n".join(lines[rules[0]:rules[-1] + 1]).strip()


# the actions are v1's: the docstring shows v1's table
LaunchBounceEnvV0.__doc__ = LaunchBounceEnvV0.__doc__.replace("{actions}", _action_table(LaunchBounceEnv.__doc__))
