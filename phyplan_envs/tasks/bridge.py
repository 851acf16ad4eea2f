"""Bridge: a pendulum hits a puck across a round table and over a bridge plank into a goal box on the ground.

Design (how the sizes and the goal range were chosen):

* Without a bridge the puck leaves the table rim (r 0.25 m) at most ~2.35 m/s and lands at most ~0.84 m from the
  table centre (0.313 m high: ~0.24 s of flight). A reference-sized plank (0.25 m) would add only ~0.2 m, so nearly
  every goal reachable with it would also be nearly reachable without it. The plank is therefore 0.75 m long: a puck
  that crosses it (release angle >= ~65 deg) leaves its end at r 1.0 m and lands 1.04-1.41 m out.
* Goals lie 0.9-1.4 m from the table centre, all beyond the ~0.84 m a puck reaches without the bridge, so without
  it the puck always falls short; for goals beyond ~1.05 m the best bridge-less attempt scores at most
  0.84/1.05 = 0.8, i.e. more than 0.2 below the best attempt with the bridge. Goals under the plank's far end
  (0.9-1.0 m) are reached by a puck that stops on the plank above them, tips off its end, or leaves the plank over
  a side edge when the plank is turned ~0.1-0.2 rad off the puck's path.
* The plank's top is 2 mm below the table top: a flush plank knocks the puck back at the seam (MuJoCo resolves the
  sliding puck's contact penetration into the plank's end face through that face), while with the step the landing
  distance is a smooth function of the release angle (tests/test_task_physics.py checks it).
* v1 (:class:`BridgeEnv`, ``PhyPlan/Bridge-v1``) makes the puck a square block facing the swing plane, so that the
  landing is not chaotic (its docstring); everything above holds for both versions.

Measured by ``python -m benchmarks.design_checks.bridge --contexts 50 --seed 0 --smooth`` (the oracle's search on
the real simulator, at most 300 simulations with the bridge and 200 without; the bridge-less search keeps the plank
at the yaw bound farther from phi and searches phi and theta alone): the share of solvable contexts (best reward
>= 0.95), the share that needs the bridge (best with it - best without it > 0.2) and how smooth the end distance
is near each optimum (over theta +- 2 deg, against a quadratic fit); ``--contexts 30 --seed 1`` is a second sample,
``--version 0`` measures v0, and ``python -m benchmarks.solvability --tasks bridge --contexts 50 --budget 300`` is
the suite's oracle on the same contexts. The figures, and the measurements behind the 2 mm step: docs/tasks.md
(*Bridge: the design and its measurements*).
"""
from __future__ import annotations

import dataclasses

from ..tools import Puck, RoundTable
from .bridge_common import (BOB_DZ, FACTS as FACTS_V0, GOAL_ANGLE, GOAL_DISTANCE, NEUTRAL_YAW,  # noqa: F401
                            PUCK_START, TABLE_HEIGHT, TABLE_RADIUS, BridgeFacts, BridgeTask, bridge_tools)
from .bridge_v0 import BridgeEnvV0  # noqa: F401  (the superseded version, importable from here too)

FACTS = dataclasses.replace(FACTS_V0, puck_shape="block")
FRICTION_PAIRS = (("table_top", "puck_table"), ("bridge_plank", "puck_plank"))   # the block's sliding surfaces


class BridgeEnv(BridgeTask):
    """``PhyPlan/Bridge-v1``: swing a pendulum into a puck, a square block facing the swing plane, so that it slides
    over a table and a bridge plank that the agent places, falls off the plank's far end and lands in the goal box.

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

    Scene: a round table (radius 0.25 m, top 0.313 m high, friction 0.2) with the puck (a square block of half edge
    17.7 mm, 1 cm thick, 0.05 kg) on its centre; the pendulum (0.3 m, 0.5 kg bob) hits it as in Slide. The bridge
    plank (0.75 m long, 0.125 m wide, 0.05 m thick, top 2 mm below the table top, friction 0.2) starts at the table
    rim and points along ``bridge_yaw``. Between attempts the bridge and the pendulum plane rest at yaw pi/4.

    Episode end: the puck's centre falls below 0.03 m (it lands; xy interpolated at the crossing), or it stops
    (speed < 0.01 m/s after 0.6 s) on the table or the plank (its xy there counts), or 4 s pass.
    Reward: ``1 - d/d0``, d the xy distance of that end point from the goal centre, d0 the same for the puck at
    rest on the table centre. ``is_success``: the end point lies within the goal box's footprint.
    Physical facts (masses, heights, radii, plank geometry, start position): :attr:`facts`, a :class:`BridgeFacts`.

    v1 (Bridge-v0: :class:`phyplan_envs.tasks.bridge_v0.BridgeEnvV0`, the puck a disc of radius 0.02 m) with the
    puck as a square block facing the swing plane.

    v1 changes only the puck's contacts, so that the landing is not chaotic. MuJoCo collides the v0 disc (a cylinder)
    with the table top and the plank through its general convex collider, whose contact points jitter as the disc
    slides and tips over the table's rim or the plank's end, so that a tiny change of the action or of the timestep
    moves some of v0's landings by centimetres. In v1 every contact the puck slides on is box-on-box, which MuJoCo
    collides exactly:

    * the puck is a square block of the disc's footprint area (half edge 17.7 mm, same mass 0.05 kg and thickness
      1 cm; :func:`phyplan_envs.block.make_block`), turned to the swing plane ``phi`` before each attempt (the bob
      hits the middle of a face; between attempts it faces the resting pendulum, ``phi = pi/4``). In robot mode the
      scene turns it, not the arm;
    * the round table top collides as a square of half edge 0.25 m turned with the block
      (:func:`phyplan_envs.block.add_square_top`): along the block's path from the table centre its rim is the
      disc's rim, 0.25 m out; the table is drawn round;
    * the puck's friction with the table top and the plank (0.2, as v0's) is a contact pair with a slow friction
      reference (:func:`phyplan_envs.block.add_friction_pair`, ``solreffriction`` (0.05, 1)): the sliding block
      stays on the table instead of hopping.

    ``python -m benchmarks.design_checks.bridge --chaos`` (``--version 0`` for v0) measures how far 200 random
    actions' landings move when every action dimension moves by 1e-8 to 1e-4 rad and when the timestep halves
    (figures: docs/tasks.md, *Bridge-v1 and the superseded Bridge-v0*). Goals, spaces, plank, pendulum, end rule and
    reward are v0's.

    Version History:

    * v0: first release (:class:`phyplan_envs.tasks.bridge_v0.BridgeEnvV0`).
    * v1: the block (above).
    """

    facts = FACTS

    def assemble(self):
        f = self.facts
        table = RoundTable(f.table_radius, f.table_height, f.table_friction, square_top=True)
        puck = Puck(self.object_start, "block", mass=f.puck_mass, faces=True, supports=(table.name,),
                    friction_pairs=FRICTION_PAIRS, friction=f.table_friction)
        return bridge_tools(self, table, puck)
