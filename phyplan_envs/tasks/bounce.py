"""Bounce: a ball dropped onto a yawed 45 degree wedge bounces off the incline and flies into a goal box."""
from __future__ import annotations

import math

import numpy as np

from .. import assets
from ..base import ActionDim, PhyPlanEnv

DROP_XY = np.array([0.0, 0.0])                 # the wedge's yaw axis: the ball is always released above it
WEDGE_POS = (DROP_XY[0], DROP_XY[1], 0.0)
WEDGE_NEUTRAL_YAW = 0.0                         # tool pose at reset, before any attempt (the obs camera sees its profile)
SIDE_TABLE_HALF = 0.1                           # reference side table: 0.2 x 0.2 x 1.0 m
SIDE_TABLE_HEIGHT = 1.0
SIDE_TABLE_XY = np.array([0.0, 0.45])           # behind the wedge, away from the goal area (goals have y < -0.3)
BALL_START = np.array([SIDE_TABLE_XY[0], SIDE_TABLE_XY[1], SIDE_TABLE_HEIGHT + assets.BALL_RADIUS])
# Goal sampling of the reference: x ~ U(-0.75, 0.75), y ~ U(-0.75, 0), redrawn until |x| > 0.3 and |y| > 0.3.
# With the wedge on its stand the landing ring (0.44-1.07 m from the wedge) covers all of it: see the docstring.
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
    Skill chain: throw (free fall onto the incline) -> bounce -> throw (projectile to the ground).

    Physical parameters: ball radius 0.02 m, 0.1 kg; the incline contact is frictionless (``condim=1``) with
    ``solref="-200000 -15"`` (``assets.ELASTIC_SOLREF``), only on the ball-incline pair (``priority=1``).
    Measured (``python -m benchmarks.design_checks.bounce --measure``): normal restitution 0.94-0.95, outgoing speed
    0.98-1.00 x incoming, launch 2-3 degrees below horizontal, the contact lasts 7 ms and the ball slides 1-2.5 cm
    down the incline; landing 0.44 m from the wedge axis at drop height 0.5 m, 0.83 m at 1.0 m and 1.07 m at 1.5 m,
    in direction ``wedge_yaw`` within 0.001 rad. Every sampled context is solvable: a grid + compass search over
    the real simulator reached reward >= 0.99 on 100 of 100 contexts (``--solvability 100``), >= 0.98 at the four
    corners of the goal region.
    The Panda (visual only) stands on a 0.5 m stand at (-0.5, 0.3) and holds the ball from the side: on the side
    table before an attempt, at the drop point for an action.
    """

    task_name = "bounce"
    object_name = "ball"
    action_dims = (
        ActionDim("wedge_yaw", -math.pi, math.pi, "rad", "yaw of the wedge (direction the ball bounces off to)"),
        ActionDim("drop_height", 0.5, 1.5, "m", "height of the ball's centre above the ground at release"),
    )
    end_rule = "landed"
    landing_height = assets.BALL_RADIUS + 0.01
    skill_chain = ("throw", "bounce", "throw")
    state_extra = ("wedge_x", "wedge_y", "impact_z")
    grip_half_width = assets.BALL_RADIUS   # the Panda's fingers close on the ball

    def build_scene(self, root):
        assets.add_table(root, SIDE_TABLE_XY[0] - SIDE_TABLE_HALF, SIDE_TABLE_XY[0] + SIDE_TABLE_HALF,
                         SIDE_TABLE_XY[1] - SIDE_TABLE_HALF, SIDE_TABLE_XY[1] + SIDE_TABLE_HALF,
                         height=SIDE_TABLE_HEIGHT, name="side_table")
        assets.add_wedge(root)
        assets.add_ball(root)
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
        return [DROP_XY[0], DROP_XY[1], assets.WEDGE_IMPACT_Z]

    def panda_placement(self):
        return {"base_pos": PANDA_BASE, "base_yaw": PANDA_YAW}

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

    # --- skill chain (issue 6): the PhyPlan agent's prediction of where the ball lands -------------------------------
    @staticmethod
    def skill_rollout(state, actions, skills):
        """Predicted landing xy of the ball for a batch of actions, from learnt skills: throw -> bounce -> throw.

        Args:
            state: the state observation as a torch tensor ``(n_state,)`` (names in ``env.state_names``).
            actions: ``(N, 2)`` float32 tensor of ``(wedge_yaw, drop_height)``.
            skills: an object with skill models ``throw`` and ``bounce`` (see :mod:`phyplan_agents.skills`).

        Returns:
            ``(N, 2)`` predicted xy (m) where the ball's centre falls through ``landing_height``.

        The ball falls from rest at ``drop_height`` to ``impact_z`` (throw with zero initial velocity: the vertical
        speed there); it bounces off the incline (bounce: the incline's nominal restitution, ``WEDGE_ANGLE``, the
        incoming vertical speed, no horizontal speed), and flies from the impact point above the wedge's yaw axis
        along ``wedge_yaw`` (throw from ``impact_z`` down to ``landing_height``).
        """
        import torch  # imported here: the envs themselves do not need torch

        from phyplan_agents.phyplan import queries as q
        from phyplan_envs.skill_scenes import restitution_of_solref

        yaw, height = actions[:, 0], actions[:, 1]
        wedge_xy, impact_z = state[5:7], state[7]             # wedge_x, wedge_y, impact_z
        zero = torch.zeros_like(yaw)
        fall = q.throw_landing(skills.throw, zero, zero, height - impact_z)
        e = torch.full_like(yaw, restitution_of_solref(assets.ELASTIC_SOLREF))
        out = skills.bounce.predict(torch.stack([e, torch.full_like(yaw, assets.WEDGE_ANGLE), fall.y[:, 2], zero],
                                                dim=1))
        reach = q.throw_landing(skills.throw, out[:, 1], out[:, 0], impact_z - BounceEnv.landing_height).y[:, 0]
        return wedge_xy + reach[:, None] * torch.stack([torch.cos(yaw), torch.sin(yaw)], dim=1)

