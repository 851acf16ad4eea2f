"""Bounce: a ball dropped onto a yawed 45 degree wedge bounces off the incline and flies into a goal box."""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from .. import assets
from ..base import ActionDim, PhyPlanEnv
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
    action_dims = (
        ActionDim("wedge_yaw", -math.pi, math.pi, "rad", "yaw of the wedge (direction the ball bounces off to)"),
        ActionDim("drop_height", 0.5, 1.5, "m", "height of the ball's centre above the ground at release"),
    )
    facts = FACTS
    end_rule = "landed"
    landing_height = FACTS.landing_height
    state_extra = ("wedge_x", "wedge_y", "impact_z")
    grip_half_width = FACTS.ball_radius    # the Panda's fingers close on the ball

    def build_scene(self, root):
        assets.add_table(root, SIDE_TABLE_XY[0] - SIDE_TABLE_HALF, SIDE_TABLE_XY[0] + SIDE_TABLE_HALF,
                         SIDE_TABLE_XY[1] - SIDE_TABLE_HALF, SIDE_TABLE_XY[1] + SIDE_TABLE_HALF,
                         height=SIDE_TABLE_HEIGHT, name="side_table")
        assets.add_wedge(root)
        assets.add_ball(root, mass=self.facts.ball_mass)
        assets.add_goal_box(root)
        if self.with_panda:   # the Panda's stand: visual only, in the Panda's geom group (hidden from the obs camera)
            root.worldbody.add("geom", name="panda_stand", type="box", group=4, rgba=(0.35, 0.35, 0.38, 1),
                               pos=(PANDA_BASE[0], PANDA_BASE[1], PANDA_BASE[2] / 2),
                               size=(PANDA_STAND_HALF, PANDA_STAND_HALF, PANDA_BASE[2] / 2), **assets.GHOST)
        assets.add_camera(root, "obs", pos=(0.0, -1.2, 2.6), lookat=(0.0, -0.12, 0.3), fovy=46)
        assets.add_camera(root, "view", pos=(1.7, -1.9, 1.7), lookat=(0.0, -0.1, 0.55), fovy=50)

    def _init_ids(self):
        super()._init_ids()
        self._wedge = self.body_id("wedge")

    def sample_context(self, rng):
        while True:
            x = rng.uniform(*GOAL_X)
            y = rng.uniform(*GOAL_Y)
            if abs(x) > GOAL_MIN_ABS and abs(y) > GOAL_MIN_ABS:
                return {"goal": np.array([x, y])}

    def reset_scene(self, context):
        self.set_body_pose(self._wedge, WEDGE_POS, yaw=WEDGE_NEUTRAL_YAW)
        self.set_object_pose(BALL_START)

    def apply_action(self, action):
        yaw, height = action
        self.set_body_pose(self._wedge, WEDGE_POS, yaw=yaw)
        self.set_object_pose((DROP_XY[0], DROP_XY[1], height))

    def task_state(self):
        return [DROP_XY[0], DROP_XY[1], self.facts.wedge_impact_z]

    def panda_placement(self):
        return {"base_pos": PANDA_BASE, "base_yaw": PANDA_YAW}

    robot_bodies = ("ball",)      # robot mode: the arm carries the ball

    def robot_plan(self, action):
        """Robot mode: the wedge is turned to ``wedge_yaw`` directly (a tool the arm need not carry); the arm picks
        the ball off the side table and lets go of it at rest at the drop point
        (:func:`phyplan_envs.panda.plans.drop_carry`)."""
        from ..panda.plans import drop_carry

        yaw, height = float(action[0]), float(action[1])
        self.set_body_pose(self._wedge, WEDGE_POS, yaw=yaw)
        drop = (DROP_XY[0], DROP_XY[1], height)
        return [drop_carry(self.object_pos(), drop, PANDA_BASE[:2], self.facts.ball_radius)]

    def hand_axes(self, action):
        """The Panda's grasp (approach, closing) for ``hand_target(action)``: horizontal, from the robot's side.

        A top-down grasp cannot reach drop heights above ~1.3 m; approaching horizontally along the line from the
        base to the ball reaches all of them.
        """
        t = self.hand_target(action)
        h = t[:2] - np.asarray(PANDA_BASE[:2])
        h = h / np.linalg.norm(h)
        return np.array([h[0], h[1], 0.0]), np.array([-h[1], h[0], 0.0])

    def hand_target(self, action):
        """Before an attempt the hand holds the ball on the side table; for ``action`` its drop point."""
        if action is None:
            return BALL_START.copy()
        return np.array([DROP_XY[0], DROP_XY[1], float(action[1])])
