"""Launch: a pendulum hits a ball off a pedestal into a goal box on the ground."""
from __future__ import annotations

import math

import numpy as np

from .. import assets
from ..base import ActionDim, PhyPlanEnv, polar
from ..tools import PendulumHitMixin

BALL_START = np.array([0.0, 0.0, assets.PEDESTAL_HEIGHT + assets.BALL_RADIUS])
GOAL_DISTANCE = (0.35, 0.6)     # m from the ball; see README "Solvability" for how the range was chosen
GOAL_ANGLE = (0.0, math.pi / 2)


class LaunchEnv(PendulumHitMixin, PhyPlanEnv):
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
    Skill chain: swing -> hit -> throw.
    """

    task_name = "launch"
    object_name = "ball"
    action_dims = (
        ActionDim("phi", 0.0, math.pi / 2, "rad", "pendulum plane angle (direction of the hit)"),
        ActionDim("theta", math.pi / 4, math.pi / 2, "rad", "release angle of the pendulum from vertical"),
    )
    end_rule = "landed"
    landing_height = assets.BALL_RADIUS + 0.01
    skill_chain = ("swing", "hit", "throw")
    state_extra = ("pivot_height",)
    object_start = BALL_START
    object_half = assets.BALL_RADIUS

    def build_scene(self, root):
        assets.add_pedestal(root, BALL_START[:2])
        assets.add_pendulum(root)
        assets.add_ball(root)
        assets.add_goal_box(root)
        assets.add_camera(root, "obs", pos=(0.3, -0.45, 1.45), lookat=(0.27, 0.27, 0.15), fovy=50)
        assets.add_camera(root, "view", pos=(1.3, -1.0, 1.1), lookat=(0.15, 0.2, 0.25), fovy=50)

    def sample_context(self, rng):
        d = rng.uniform(*GOAL_DISTANCE)
        a = rng.uniform(*GOAL_ANGLE)
        return {"goal": BALL_START[:2] + polar(d, a)}

    def task_state(self):
        return [BALL_START[2] + assets.PENDULUM_LENGTH]

    def panda_placement(self):
        return {"base_pos": (-0.6, -0.25, 0.0), "base_yaw": 0.4}

    # --- skill chain (issue 6): the PhyPlan agent's prediction of where the ball lands -------------------------------
    @staticmethod
    def skill_rollout(state, actions, skills):
        """Predicted landing xy of the ball for a batch of actions, from learnt skills: swing -> hit -> throw.

        Args:
            state: the state observation as a torch tensor ``(n_state,)`` (names in ``env.state_names``).
            actions: ``(N, 2)`` float32 tensor of ``(phi, theta)``.
            skills: an object with skill models ``swing``, ``hit``, ``throw`` (see :mod:`phyplan_agents.skills`).

        Returns:
            ``(N, 2)`` predicted xy (m) where the ball's centre falls through ``landing_height``.

        The bob, released at theta, reaches the bottom of its arc at the ball's height (swing: first theta = 0,
        speed = |omega| * l); it hits the ball (hit: bob 0.5 kg, ball 0.1 kg), which leaves the pedestal top
        horizontally along phi (throw with v_ver = 0) and lands when it has dropped from its start height to
        ``landing_height``.
        """
        import torch  # imported here: the envs themselves do not need torch

        from phyplan_agents.phyplan import queries as q

        phi, theta = actions[:, 0], actions[:, 1]
        start = state[2:5]                                   # object_x, object_y, object_z
        v_bob = q.swing_bottom_speed(skills.swing, theta)
        v_ball = q.hit_speed(skills.hit, assets.BOB_MASS, assets.BALL_MASS, v_bob)
        drop = start[2] - LaunchEnv.landing_height
        reach = q.throw_landing(skills.throw, v_ball, 0.0, drop).y[:, 0]
        return start[:2] + reach[:, None] * torch.stack([torch.cos(phi), torch.sin(phi)], dim=1)
