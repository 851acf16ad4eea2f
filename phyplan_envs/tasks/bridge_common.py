"""What the Bridge versions (:mod:`phyplan_envs.tasks.bridge` v1, :mod:`phyplan_envs.tasks.bridge_v0` v0) share by
definition: the facts, the goal range, the plank and the arm's stand, the tool assembly around a table and a puck
(:func:`bridge_tools`) and :class:`BridgeTask`, the declarations of the task (not registered itself). The design
notes: :mod:`phyplan_envs.tasks.bridge`."""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from .. import assets
from ..base import PhyPlanEnv
from ..block import BLOCK_HALF
from ..tools import PENDULUM_DIMS, GoalBox, PendulumFacts, PendulumRig, Plank, Puck, RoundTable
from ..tools.supports import polar_goal


@dataclass(frozen=True)
class BridgeFacts(PendulumFacts):
    """The Bridge scene's physical facts (m, kg): what the scene is built from and what a model of the task reads.

    Attributes:
        table_radius, table_height, table_friction: the round table (centred on the origin) and its top.
        bridge_length, bridge_width, bridge_thick: the plank, from the table rim outwards.
        bridge_drop: the plank's top below the table top (a flush plank knocks the puck back: tasks/bridge.py).
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
GOAL_DISTANCE = (0.9, 1.4)      # m from the table centre (reference U(0.5, 1.5)); tasks/bridge.py's docstring
GOAL_ANGLE = (0.0, math.pi / 2)
NEUTRAL_YAW = math.pi / 4       # bridge yaw and pendulum plane at reset (fixed, so the image observation is too)
# Robot mode: the plank turns on a pivot at the table centre (hinge "bridge_yaw", locked but while the arm turns it);
# the arm stands where it reaches the plank at every yaw and the bob at every release (docs/robot.md)
ROBOT_BASE = (-0.4, 0.0, 0.0)
PLANK_GRASP_R = 0.29            # m from the table centre: where the fingers hold the plank
PLANK_ROBOT_MASS = 0.5          # kg: the plank the arm turns (only its inertia about the pivot matters)
CAMERAS = (("obs", (0.56, -0.3, 2.5), (0.56, 0.58, 0.0), 47), ("view", (1.7, -1.7, 1.6), (0.35, 0.3, 0.2), 52))


def bridge_tools(env, table: RoundTable, puck: Puck) -> list:
    """The Bridge assembly around ``table`` and ``puck``: the plank from the table's rim, the pendulum hitting the
    puck (the hand's tool), the goal box; sets ``env.plank``, ``env.pendulum`` and ``env.hand_tool``."""
    f = env.facts
    env.plank = plank = Plank(table, f.bridge_length, f.bridge_width, f.bridge_thick, f.bridge_drop, NEUTRAL_YAW,
                              ROBOT_BASE[:2], PLANK_GRASP_R, PLANK_ROBOT_MASS)
    env.pendulum = env.hand_tool = PendulumRig(puck, bob_dz=f.bob_dz, bob_mass=f.bob_mass, rest_phi=NEUTRAL_YAW)
    return [table, plank, env.pendulum, puck, GoalBox()]


class BridgeTask(PhyPlanEnv):
    """The Bridge task's declarations: its actions (the pendulum's, the plank's yaw), state, goals, end rule and the
    Panda's stands. A version declares its ``facts`` and ``assemble``s :func:`bridge_tools` around its puck."""

    task_name = "bridge"
    object_name = "puck"
    action_dims = PENDULUM_DIMS + Plank.dims
    facts = FACTS
    end_rule = "landed"
    landing_height = FACTS.landing_height
    state_extra = ("table_radius", "table_height", "bridge_length", "bridge_width")
    object_start = PUCK_START
    cameras = CAMERAS
    panda_base = ((-0.6, -0.3, 0.0), 0.4)
    robot_base = (ROBOT_BASE, 0.0)

    def sample_goal(self, rng):
        return polar_goal(rng, PUCK_START, GOAL_DISTANCE, GOAL_ANGLE)

    def task_state(self):
        f = self.facts
        return [f.table_radius, f.table_height, f.bridge_length, f.bridge_width]

    def bridge_yaw(self) -> float:
        """The bridge's current yaw (rad): ``NEUTRAL_YAW`` after reset, the action's ``bridge_yaw`` after a step."""
        return self.plank.yaw()
