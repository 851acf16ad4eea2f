"""Bridge-v0, superseded by Bridge-v1 (:mod:`phyplan_envs.tasks.bridge`) and kept registered and reproducible.

Frozen: this file changes only if the v0 outcomes would otherwise change. What the versions share by definition:
:mod:`phyplan_envs.tasks.bridge_common`; the design notes of both: :mod:`phyplan_envs.tasks.bridge`.
"""
from __future__ import annotations

from ..tools import Puck, RoundTable
from .bridge_common import FACTS, BridgeFacts, BridgeTask, bridge_tools  # noqa: F401  (BridgeFacts: its facts' type)


class BridgeEnvV0(BridgeTask):
    """``PhyPlan/Bridge-v0``: swing a pendulum into a puck so that it slides over a table and a bridge plank that the
    agent places, falls off the plank's far end and lands in the goal box on the ground.

    ==============  ==============  ======  =============================================================
    action          bounds          unit    meaning
    ==============  ==============  ======  =============================================================
    ``phi``         [0, pi/2]       rad     plane of the pendulum's swing (direction the puck is hit, from +x)
    ``theta``       [pi/4, pi/2]    rad     release angle of the pendulum from vertical
    ``bridge_yaw``  [0, pi/2]       rad     direction of the bridge plank from the table centre (from +x)
    ==============  ==============  ======  =============================================================

    State observation (float32, m): ``goal_x, goal_y, object_x, object_y, object_z`` (the puck),
    ``table_radius`` (0.25), ``table_height`` (0.313), ``bridge_length`` (0.75), ``bridge_width`` (0.125).

    Context: the goal box (0.1 x 0.1, 0.02 m walls, on the ground) at distance U(0.9, 1.4) m from the table centre
    in direction U(0, pi/2). Every goal lies beyond the ~0.84 m a puck reaches without the bridge.

    Scene: a round table (radius 0.25 m, top 0.313 m high, friction 0.2) with the puck (radius 0.02 m, 1 cm thick,
    0.05 kg) on its centre; the pendulum (0.3 m, 0.5 kg bob) hits it as in Slide. The bridge plank (0.75 m long,
    0.125 m wide, 0.05 m thick, top 2 mm below the table top, friction 0.2) starts at the table rim and points
    along ``bridge_yaw``. Between attempts the bridge and the pendulum plane rest at yaw pi/4.

    Episode end: the puck's centre falls below 0.03 m (it lands; xy interpolated at the crossing), or it stops
    (speed < 0.01 m/s after 0.6 s) on the table or the plank (its xy there counts), or 4 s pass.
    Reward: ``1 - d/d0``, d the xy distance of that end point from the goal centre, d0 the same for the puck at
    rest on the table centre. ``is_success``: the end point lies within the goal box's footprint.
    Physical facts (masses, heights, radii, plank geometry, start position): :attr:`facts`, a :class:`BridgeFacts`.

    Version History:

    * v0: first release: the pendulum-hits-puck-over-a-placed-bridge task with goals 0.9-1.4 m away (kept
      registered and reproducible; superseded by v1, :class:`phyplan_envs.tasks.bridge.BridgeEnv`).
    * v1: the puck is a square block facing the swing plane (:class:`phyplan_envs.tasks.bridge.BridgeEnv`).
    """

    facts = FACTS

    def assemble(self):
        f = self.facts
        return bridge_tools(self, RoundTable(f.table_radius, f.table_height, f.table_friction),
                            Puck(self.object_start, mass=f.puck_mass))
