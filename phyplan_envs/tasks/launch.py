"""Launch: a pendulum hits a ball off a pedestal into a goal box on the ground."""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from .. import assets
from ..base import PhyPlanEnv
from ..tools import PENDULUM_DIMS, Ball, GoalBox, Pedestal, PendulumFacts, PendulumRig
from ..tools.supports import polar_goal


@dataclass(frozen=True)
class LaunchFacts(PendulumFacts):
    """The Launch scene's physical facts (m, kg): what the scene is built from and what a model of the task reads.

    Attributes:
        pedestal_xy, pedestal_height: where the (frictionless) pedestal stands and the height of its top.
        ball_radius, ball_mass: the ball; :attr:`ball_start` is its centre at rest on the pedestal.
        landing_height: the episode ends when the ball's centre falls through this height (it lands).
        pendulum_length, bob_mass, bob_dz: the pendulum rig (:class:`phyplan_envs.tools.PendulumFacts`).
    """

    pedestal_xy: tuple[float, float] = (0.0, 0.0)
    pedestal_height: float = assets.PEDESTAL_HEIGHT
    ball_radius: float = assets.BALL_RADIUS
    ball_mass: float = assets.BALL_MASS
    landing_height: float = assets.BALL_RADIUS + 0.01

    @property
    def ball_start(self) -> tuple[float, float, float]:
        return (self.pedestal_xy[0], self.pedestal_xy[1], self.pedestal_height + self.ball_radius)


FACTS = LaunchFacts()
BALL_START = np.array(FACTS.ball_start)
GOAL_DISTANCE = (0.35, 0.6)     # m from the ball; see docs/tasks.md "Every context is solvable" for how it was chosen
GOAL_ANGLE = (0.0, math.pi / 2)


class LaunchEnv(PhyPlanEnv):
    """``PhyPlan/Launch-v0``: swing a pendulum into a ball resting on a pedestal so that it flies into the goal box.

    ==========  =====================  ==========  =================================================================
    action      bounds                 unit        meaning
    ==========  =====================  ==========  =================================================================
    ``phi``     [0, pi/2]              rad         plane of the pendulum's swing (direction the ball is hit, from +x)
    ``theta``   [pi/4, pi/2]           rad         release angle of the pendulum from vertical
    ==========  =====================  ==========  =================================================================

    State observation: ``goal_x, goal_y, object_x, object_y, object_z, pivot_height`` (m).
    Context: goal at distance U(0.35, 0.6) m from the ball, direction U(0, pi/2).
    Episode end: the ball's centre falls below ``BALL_RADIUS + 0.01`` m (it lands), the ball rests, or 4 s pass.
    Reward: ``1 - d/d0`` with d the xy distance of the ball's landing point from the goal centre.
    Physical facts (masses, heights, radii, start position): :attr:`facts`, a :class:`LaunchFacts`.

    Version History:

    * v0: first release: the pendulum-hits-ball-off-a-pedestal task with goals 0.35-0.6 m away.
    """

    task_name = "launch"
    object_name = "ball"
    action_dims = PENDULUM_DIMS
    facts = FACTS
    end_rule = "landed"
    landing_height = FACTS.landing_height
    state_extra = ("pivot_height",)
    object_start = BALL_START
    cameras = (("obs", (0.3, -0.45, 1.45), (0.27, 0.27, 0.15), 50), ("view", (1.3, -1.0, 1.1), (0.15, 0.2, 0.25), 50))
    panda_base = ((-0.6, -0.25, 0.0), 0.4)

    def assemble(self):
        f = self.facts
        ball = Ball(self.object_start, mass=f.ball_mass)
        self.pendulum = self.hand_tool = PendulumRig(ball, bob_dz=f.bob_dz, bob_mass=f.bob_mass)
        return [Pedestal(BALL_START[:2]), self.pendulum, ball, GoalBox()]

    def sample_goal(self, rng):
        return polar_goal(rng, BALL_START, GOAL_DISTANCE, GOAL_ANGLE)

    def task_state(self):
        return [BALL_START[2] + self.facts.pendulum_length]
