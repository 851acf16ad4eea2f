"""Slide: a pendulum hits a puck that slides on a table and comes to rest near the goal."""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from .. import assets
from ..base import PhyPlanEnv
from ..tools import PENDULUM_DIMS, GoalBox, PendulumFacts, PendulumRig, Puck, Table
from ..tools.supports import polar_goal


@dataclass(frozen=True)
class SlideFacts(PendulumFacts):
    """The Slide scene's physical facts (m, kg): what the scene is built from and what a model of the task reads.

    Attributes:
        puck_xy: where the puck rests; :attr:`puck_start` is its centre at rest on the table.
        puck_radius, puck_half_height, puck_mass: the puck (a 1 cm thick disc).
        table_height, table_friction: the table top and its sliding friction (the mu the slide skill learns).
        bob_dz: the bob's centre 4 mm below the puck's (a higher bob rides over the puck at speed).
        pendulum_length, bob_mass: the pendulum rig (:class:`phyplan_envs.tools.PendulumFacts`).
    """

    puck_xy: tuple[float, float] = (0.0, 0.0)
    puck_radius: float = assets.PUCK_RADIUS
    puck_half_height: float = assets.PUCK_HALF_HEIGHT
    puck_mass: float = assets.PUCK_MASS
    table_height: float = assets.TABLE_HEIGHT
    table_friction: float = assets.TABLE_FRICTION
    bob_dz: float = -0.004

    @property
    def puck_start(self) -> tuple[float, float, float]:
        return (self.puck_xy[0], self.puck_xy[1], self.table_height + self.puck_half_height)


FACTS = SlideFacts()
PUCK_START = np.array(FACTS.puck_start)
BOB_DZ = FACTS.bob_dz
GOAL_DISTANCE = (0.55, 1.6)     # m from the puck; see docs/tasks.md "Every context is solvable"
GOAL_ANGLE = (0.0, math.pi / 2)


class SlideEnv(PhyPlanEnv):
    """``PhyPlan/Slide-v0``: swing a pendulum into a puck so that it slides over the table and stops on the goal.

    ==========  =====================  ==========  =================================================================
    action      bounds                 unit        meaning
    ==========  =====================  ==========  =================================================================
    ``phi``     [0, pi/2]              rad         plane of the pendulum's swing (direction the puck is hit)
    ``theta``   [pi/4, pi/2]           rad         release angle of the pendulum from vertical
    ==========  =====================  ==========  =================================================================

    State observation: ``goal_x, goal_y, object_x, object_y, object_z, table_height`` (m).
    Context: goal (a flat 0.1 x 0.1 marker on the table) at distance U(0.55, 1.6) m, direction U(0, pi/2).
    Episode end: the puck has stopped (speed < 0.01 m/s after 0.6 s), or 4 s pass.
    Reward: ``1 - d/d0`` with d the xy distance of the puck's resting point from the goal centre.
    Table friction 0.2 (the mu the sliding PINN learns).
    Physical facts (masses, heights, radii, friction, start position): :attr:`facts`, a :class:`SlideFacts`.

    Version History:

    * v0: first release: the pendulum-hits-puck-across-a-table task with goals 0.55-1.6 m away.
    """

    task_name = "slide"
    object_name = "puck"
    action_dims = PENDULUM_DIMS
    facts = FACTS
    end_rule = "rest"
    state_extra = ("table_height",)
    object_start = PUCK_START
    puck_shape = "disc"
    cameras = (("obs", (0.65, -0.55, 2.3), (0.65, 0.62, 0.3), 50), ("view", (2.0, -1.7, 1.9), (0.45, 0.45, 0.3), 55))
    panda_base = ((-0.6, -0.3, 0.0), 0.4)

    def assemble(self):
        f = self.facts
        puck = Puck(self.object_start, self.puck_shape, mass=f.puck_mass)
        self.pendulum = self.hand_tool = PendulumRig(puck, bob_dz=f.bob_dz, bob_mass=f.bob_mass)
        return [Table((-0.25, 1.9, -0.25, 1.9), f.table_height, f.table_friction), self.pendulum, puck,
                GoalBox(walls=False, base_z=f.table_height)]

    def sample_goal(self, rng):
        return polar_goal(rng, PUCK_START, GOAL_DISTANCE, GOAL_ANGLE)

    def task_state(self):
        return [self.facts.table_height]
