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
import math
from dataclasses import dataclass

import numpy as np

from .. import assets
from ..base import ActionDim, PhyPlanEnv, polar
from ..block import BLOCK_HALF, add_friction_pair, add_square_top, make_block, turn_body
from ..tools import PendulumFacts, PendulumHitMixin


@dataclass(frozen=True)
class BridgeFacts(PendulumFacts):
    """The Bridge scene's physical facts (m, kg): what the scene is built from and what a model of the task reads.

    Attributes:
        table_radius, table_height, table_friction: the round table (centred on the origin) and its top.
        bridge_length, bridge_width, bridge_thick: the plank, from the table rim outwards.
        bridge_drop: the plank's top below the table top (a flush plank knocks the puck back: module docstring).
        puck_radius, puck_half_height, puck_mass: the puck; :attr:`puck_start` is its centre at rest on the table
            centre.
        puck_shape, puck_half_edge: ``"disc"`` (v0: a cylinder of radius ``puck_radius``) or ``"block"`` (v1: a
            square block of half edge ``puck_half_edge``, the disc's footprint area, same thickness and mass,
            facing the swing plane).
        landing_height: the episode ends when the puck's centre falls through this height (it lands); above the
            goal walls, so walls never change the outcome.
        bob_dz: as in Slide, the bob's centre 4 mm below the puck's (a higher bob rides over it).
        pendulum_length, bob_mass: the pendulum rig (:class:`phyplan_envs.tools.PendulumFacts`).
    """

    table_radius: float = assets.BRIDGE_TABLE_RADIUS
    table_height: float = assets.TABLE_HEIGHT
    table_friction: float = assets.TABLE_FRICTION
    bridge_length: float = assets.BRIDGE_LENGTH
    bridge_width: float = assets.BRIDGE_WIDTH
    bridge_thick: float = assets.BRIDGE_THICK
    bridge_drop: float = assets.BRIDGE_DROP
    puck_radius: float = assets.PUCK_RADIUS
    puck_half_height: float = assets.PUCK_HALF_HEIGHT
    puck_mass: float = assets.PUCK_MASS
    puck_shape: str = "disc"
    puck_half_edge: float = BLOCK_HALF
    landing_height: float = assets.PUCK_RADIUS + 0.01    # 0.03 m
    bob_dz: float = -0.004

    @property
    def puck_start(self) -> tuple[float, float, float]:
        return (0.0, 0.0, self.table_height + self.puck_half_height)


FACTS = BridgeFacts()
TABLE_RADIUS = FACTS.table_radius
TABLE_HEIGHT = FACTS.table_height
PUCK_START = np.array(FACTS.puck_start)   # on the table centre
BOB_DZ = FACTS.bob_dz
GOAL_DISTANCE = (0.9, 1.4)      # m from the table centre (reference U(0.5, 1.5)); see the module docstring
GOAL_ANGLE = (0.0, math.pi / 2)
NEUTRAL_YAW = math.pi / 4       # bridge yaw and pendulum plane at reset (fixed, so the image observation is too)
# Robot mode: the plank turns on a pivot at the table centre (hinge "bridge_yaw", locked but while the arm turns it);
# the arm stands where it reaches the plank at every yaw and the bob at every release (docs/robot.md)
ROBOT_BASE = (-0.4, 0.0, 0.0)
PLANK_GRASP_R = 0.29            # m from the table centre: where the fingers hold the plank
PLANK_ROBOT_MASS = 0.5          # kg: the plank the arm turns (only its inertia about the pivot matters)


class BridgeEnvV0(PendulumHitMixin, PhyPlanEnv):
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
      registered and reproducible; superseded by v1, :class:`BridgeEnv`).
    * v1: the puck is a square block facing the swing plane (:class:`BridgeEnv`).
    """

    task_name = "bridge"
    object_name = "puck"
    action_dims = (
        ActionDim("phi", 0.0, math.pi / 2, "rad", "pendulum plane angle (direction of the hit)"),
        ActionDim("theta", math.pi / 4, math.pi / 2, "rad", "release angle of the pendulum from vertical"),
        ActionDim("bridge_yaw", 0.0, math.pi / 2, "rad", "direction of the bridge plank from the table centre"),
    )
    facts = FACTS
    end_rule = "landed"
    landing_height = FACTS.landing_height
    state_extra = ("table_radius", "table_height", "bridge_length", "bridge_width")
    object_start = PUCK_START
    object_half = FACTS.puck_radius
    bob_dz = FACTS.bob_dz
    rest_phi = NEUTRAL_YAW

    def build_scene(self, root):
        f = self.facts
        assets.add_round_table(root, f.table_radius, f.table_height, friction=f.table_friction)
        assets.add_bridge(root, f.table_radius, f.table_height, length=f.bridge_length, width=f.bridge_width,
                          thick=f.bridge_thick, drop=f.bridge_drop, friction=f.table_friction)
        assets.add_pendulum(root, bob_mass=f.bob_mass)
        assets.add_puck(root, mass=f.puck_mass)
        assets.add_goal_box(root)
        assets.add_camera(root, "obs", pos=(0.56, -0.3, 2.5), lookat=(0.56, 0.58, 0.0), fovy=47)
        assets.add_camera(root, "view", pos=(1.7, -1.7, 1.6), lookat=(0.35, 0.3, 0.2), fovy=52)

    def sample_context(self, rng):
        d = rng.uniform(*GOAL_DISTANCE)
        a = rng.uniform(*GOAL_ANGLE)
        return {"goal": PUCK_START[:2] + polar(d, a)}

    @property
    def _bridge(self) -> int:
        if getattr(self, "_bridge_id", None) is None:
            self._bridge_id = self.body_id("bridge")
        return self._bridge_id

    def reset_scene(self, context):
        self.set_body_pose(self._bridge, (0.0, 0.0, 0.0), yaw=NEUTRAL_YAW)
        super().reset_scene(context)

    def apply_action(self, action):
        self.set_body_pose(self._bridge, (0.0, 0.0, 0.0), yaw=action[2])
        super().apply_action(action)

    def task_state(self):
        f = self.facts
        return [f.table_radius, f.table_height, f.bridge_length, f.bridge_width]

    def bridge_yaw(self) -> float:
        """The bridge's current yaw (rad): ``NEUTRAL_YAW`` after reset, the action's ``bridge_yaw`` after a step."""
        w, _, _, z = self.model.body_quat[self._bridge]
        return 2.0 * math.atan2(z, w)

    def panda_placement(self):
        return {"base_pos": (-0.6, -0.3, 0.0), "base_yaw": 0.4}

    # --- robot mode -------------------------------------------------------------------------------------------------
    robot_bodies = ("bridge", "pendulum_arm")
    robot_latches = ("bridge_yaw",)

    def robot_placement(self):
        return {"base_pos": ROBOT_BASE, "base_yaw": 0.0}

    def robot_scene(self, root):
        """The plank turns about the table's axis (the arm turns it); it does not touch the table it sits under."""
        body = root.find("body", "bridge")
        body.add("joint", name="bridge_yaw", type="hinge", axis=(0, 0, 1), damping=2.0)
        reach = self.facts.table_radius + self.facts.bridge_length / 2
        body.add("inertial", pos=(reach, 0, self.facts.table_height), mass=PLANK_ROBOT_MASS,
                 diaginertia=(0.01, 0.05, 0.05))
        root.contact.add("exclude", body1=body, body2=root.find("body", "table"))

    def robot_plan(self, action):
        """Robot mode: the arm turns the plank from its rest yaw to ``bridge_yaw``, then swings the pendulum as in
        the other pendulum tasks (:func:`phyplan_envs.panda.plans.plank_carry`, ``PendulumHitMixin.robot_plan``)."""
        from ..panda.plans import plank_carry

        f = self.facts
        plank = plank_carry(NEUTRAL_YAW, float(action[2]), PLANK_GRASP_R, f.bridge_width, f.bridge_thick,
                            f.table_height - f.bridge_drop, ROBOT_BASE[:2])
        return [plank] + super().robot_plan(action)


class BridgeEnv(BridgeEnvV0):
    """``PhyPlan/Bridge-v1``: Bridge-v0 (below) with the puck as a square block facing the swing plane.

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

    * v0: first release (:class:`BridgeEnvV0`).
    * v1: the block (above).
    """

    facts = dataclasses.replace(FACTS, puck_shape="block")
    object_half = BLOCK_HALF

    def build_scene(self, root):
        super().build_scene(root)
        f = self.facts
        make_block(root, "puck_geom")
        add_square_top(root, "table_top", f.table_radius, **assets.WORLD)
        for geom, pair in (("table_top", "puck_table"), ("bridge_plank", "puck_plank")):
            add_friction_pair(root, "puck_geom", geom, pair, f.table_friction, soft_reference=True)

    @property
    def _table(self) -> int:
        if getattr(self, "_table_id", None) is None:
            self._table_id = self.body_id("table")
        return self._table_id

    def face_swing_plane(self, phi: float) -> None:
        """Turn the block (at its start, at rest) and the table's square collider to the swing plane ``phi``."""
        self.set_object_pose(self.object_start, quat=assets.yaw_quat(phi))
        turn_body(self.model, self._table, phi)

    def place_pendulum(self, phi: float, theta: float) -> None:
        super().place_pendulum(phi, theta)
        self.face_swing_plane(phi)

    def robot_plan(self, action):
        """Robot mode: as v0 (:meth:`BridgeEnvV0.robot_plan`), the scene turning the block to ``phi`` first."""
        self.face_swing_plane(float(action[0]))
        return super().robot_plan(action)


BridgeEnv.__doc__ += "\n    The previous version, BridgeEnvV0:\n" + (BridgeEnvV0.__doc__ or "")
