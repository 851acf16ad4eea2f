"""Bounce: a ball dropped onto a yawed 45 degree wedge bounces off the incline and flies into a goal box."""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from .. import assets
from ..base import PhyPlanEnv
from ..tools import DropBall, GoalBox, PandaStand, Table, Wedge
from ..contact import restitution_of_solref

SIDE_TABLE_HALF = 0.1                           # reference side table: 0.2 x 0.2 x 1.0 m


@dataclass(frozen=True)
class BounceFacts:
    """The Bounce scene's physical facts (m, kg, rad): what the scene is built from and what a model of the task reads.

    Attributes:
        drop_xy: the wedge's yaw axis; the ball is always released straight above it.
        side_table_xy, side_table_height: the side table the ball rests on at reset (behind the wedge, away from
            the goal area: goals have y < -0.3).
        ball_radius, ball_mass: the ball; :attr:`ball_start` is its centre at rest on the side table.
        wedge_angle: the incline's angle (45 degrees).
        wedge_impact_z: height of the ball's centre when it meets the incline above the yaw axis.
        incline_solref: the ball-incline contact's MuJoCo ``solref`` (frictionless, ``condim=1``).
        incline_restitution: its nominal restitution (:func:`phyplan_envs.contact.restitution_of_solref`).
        landing_height: the episode ends when the ball's centre falls through this height (it lands).
    """

    drop_xy: tuple[float, float] = (0.0, 0.0)
    side_table_xy: tuple[float, float] = (0.0, 0.45)
    side_table_height: float = 1.0
    ball_radius: float = assets.BALL_RADIUS
    ball_mass: float = assets.BALL_MASS
    wedge_angle: float = assets.WEDGE_ANGLE
    wedge_impact_z: float = assets.WEDGE_IMPACT_Z
    incline_solref: str = assets.ELASTIC_SOLREF
    incline_restitution: float = restitution_of_solref(assets.ELASTIC_SOLREF)
    landing_height: float = assets.BALL_RADIUS + 0.01

    @property
    def ball_start(self) -> tuple[float, float, float]:
        return (self.side_table_xy[0], self.side_table_xy[1], self.side_table_height + self.ball_radius)


FACTS = BounceFacts()
DROP_XY = np.array(FACTS.drop_xy)
WEDGE_POS = (DROP_XY[0], DROP_XY[1], 0.0)
WEDGE_NEUTRAL_YAW = 0.0          # tool pose at reset, before any attempt (the obs camera sees its profile)
SIDE_TABLE_HEIGHT = FACTS.side_table_height
SIDE_TABLE_XY = np.array(FACTS.side_table_xy)
BALL_START = np.array(FACTS.ball_start)
# Goal sampling of the reference: x ~ U(-0.75, 0.75), y ~ U(-0.75, 0), redrawn until |x| > 0.3 and |y| > 0.3.
# With the wedge on its stand the landing ring (0.44-1.07 m from the wedge) covers all of it: see the docstring
# and docs/tasks.md (Bounce).
GOAL_X = (-0.75, 0.75)
GOAL_Y = (-0.75, 0.0)
GOAL_MIN_ABS = 0.3
# The Panda stands on a 0.5 m stand beside the wedge: from the ground its hand could not reach the 1.5 m drop height
# (measured with phyplan_envs.panda's IK: the grasp point is within 0.1 mm of every drop point 0.5-1.5 m and of the
# ball on the side table with the horizontal grasp of ``hand_axes``).
PANDA_BASE = (-0.5, 0.3, 0.5)
PANDA_YAW = -0.5
PANDA_STAND_HALF = 0.09


class BounceEnv(PhyPlanEnv):
    """``PhyPlan/Bounce-v0``: drop a ball onto a yawed 45 degree wedge so that it bounces into the goal box.

    ==============  =====================  ==========  =============================================================
    action          bounds                 unit        meaning
    ==============  =====================  ==========  =============================================================
    ``wedge_yaw``   [-pi, pi]              rad         yaw of the wedge about its vertical axis through the origin;
                                                       the ball flies off along direction ``wedge_yaw`` (from +x)
    ``drop_height`` [0.5, 1.5]             m           height of the ball's centre above the ground at release;
                                                       a higher drop lands farther
    ==============  =====================  ==========  =============================================================

    Scene: at reset the ball rests on a 0.2 x 0.2 x 1.0 m side table at (0, 0.45); the wedge (base 0.3 x 0.3, 45
    degree incline, ridge 0.3 m above its base) stands on a round stand (radius 0.22 m, 0.15 m high) at the origin in
    a fixed neutral pose (yaw 0). An attempt yaws the wedge, places the ball at rest at ``(0, 0, drop_height)``
    (straight above the yaw axis, so the ball meets the incline at the same point for every yaw) and releases it.

    State observation (float32, metres): ``goal_x, goal_y, object_x, object_y, object_z`` (the ball on the side
    table after reset, its landing point after a step), then ``wedge_x, wedge_y`` (the wedge's yaw axis = the drop
    point, (0, 0)) and ``impact_z`` (height of the ball's centre when it meets the incline, 0.328 m).
    Context: goal x ~ U(-0.75, 0.75), y ~ U(-0.75, 0), redrawn until |x| > 0.3 and |y| > 0.3 (the reference sampler,
    unchanged): 0.42-1.06 m from the wedge.
    Episode end: the ball's centre falls below ``BALL_RADIUS + 0.01`` m (it lands; xy interpolated at the crossing),
    the ball rests, or 4 s pass.
    Reward: ``1 - d/d0`` with d the xy distance of the landing point from the goal centre and d0 that of the ball on
    the side table at reset (0.81-1.42 m).
    Physical facts (the numbers a model of the task needs): :attr:`facts`, a :class:`BounceFacts`.

    Physical parameters: ball radius 0.02 m, 0.1 kg; the incline contact is frictionless (``condim=1``) with
    ``solref="-200000 -15"`` (``assets.ELASTIC_SOLREF``), only on the ball-incline pair (``priority=1``).
    The ball lands 0.44 m from the wedge axis at drop height 0.5 m and 1.07 m at 1.5 m, in direction ``wedge_yaw``
    (tests/test_task_physics.py checks both). ``python -m benchmarks.design_checks.bounce --measure`` measures the
    incline's restitution, the outgoing speed and angle, the contact and the landing distance per drop height;
    ``--solvability 100`` runs the oracle's search on 100 sampled contexts (every one solvable; figures:
    docs/tasks.md, *Bounce: the measured bounce*).
    The Panda (visual only) stands on a 0.5 m stand at (-0.5, 0.3) and holds the ball from the side: on the side
    table before an attempt, at the drop point for an action.

    Version History:

    * v0: first release: the ball-dropped-onto-a-yawed-wedge task with the reference goal sampler.
    """

    task_name = "bounce"
    object_name = "ball"
    action_dims = Wedge.dims + DropBall.dims
    facts = FACTS
    end_rule = "landed"
    landing_height = FACTS.landing_height
    state_extra = ("wedge_x", "wedge_y", "impact_z")
    grip_half_width = FACTS.ball_radius    # the Panda's fingers close on the ball
    cameras = (("obs", (0.0, -1.2, 2.6), (0.0, -0.12, 0.3), 46), ("view", (1.7, -1.9, 1.7), (0.0, -0.1, 0.55), 50))
    panda_base = (PANDA_BASE, PANDA_YAW)

    def assemble(self):
        x, y = SIDE_TABLE_XY
        side = Table((x - SIDE_TABLE_HALF, x + SIDE_TABLE_HALF, y - SIDE_TABLE_HALF, y + SIDE_TABLE_HALF),
                     SIDE_TABLE_HEIGHT, name="side_table")
        self.hand_tool = DropBall(BALL_START, DROP_XY, PANDA_BASE[:2], mass=self.facts.ball_mass)
        tools = [side, Wedge(WEDGE_POS, WEDGE_NEUTRAL_YAW), self.hand_tool, GoalBox()]
        if self.with_panda:   # the Panda's stand: visual only, in the Panda's geom group (hidden from the obs camera)
            tools.append(PandaStand(PANDA_BASE, PANDA_STAND_HALF))
        return tools

    def sample_goal(self, rng):
        while True:
            x = rng.uniform(*GOAL_X)
            y = rng.uniform(*GOAL_Y)
            if abs(x) > GOAL_MIN_ABS and abs(y) > GOAL_MIN_ABS:
                return np.array([x, y])

    def task_state(self):
        return [DROP_XY[0], DROP_XY[1], self.facts.wedge_impact_z]
