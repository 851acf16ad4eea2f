"""Slide: a pendulum hits a puck that slides on a table and comes to rest near the goal."""
from __future__ import annotations

import math

import numpy as np

from .. import assets
from ..base import ActionDim, PhyPlanEnv, polar
from ..tools import PendulumHitMixin

PUCK_START = np.array([0.0, 0.0, assets.TABLE_HEIGHT + assets.PUCK_HALF_HEIGHT])
BOB_DZ = -0.004                 # bob centre 4 mm below the puck centre (a higher bob rides over the puck at speed)
GOAL_DISTANCE = (0.55, 1.6)     # m from the puck; see README "Solvability"
GOAL_ANGLE = (0.0, math.pi / 2)


class SlideEnv(PendulumHitMixin, PhyPlanEnv):
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
    Table friction 0.2 (the mu the sliding PINN learns). Skill chain: swing -> hit -> slide.
    """

    task_name = "slide"
    object_name = "puck"
    action_dims = (
        ActionDim("phi", 0.0, math.pi / 2, "rad", "pendulum plane angle (direction of the hit)"),
        ActionDim("theta", math.pi / 4, math.pi / 2, "rad", "release angle of the pendulum from vertical"),
    )
    end_rule = "rest"
    skill_chain = ("swing", "hit", "slide")
    state_extra = ("table_height",)
    object_start = PUCK_START
    object_half = assets.PUCK_RADIUS
    bob_dz = BOB_DZ
    goal_walls = False

    def build_scene(self, root):
        assets.add_table(root, -0.25, 1.9, -0.25, 1.9)
        assets.add_pendulum(root)
        assets.add_puck(root)
        assets.add_goal_box(root, walls=False, base_z=assets.TABLE_HEIGHT)
        assets.add_camera(root, "obs", pos=(0.65, -0.55, 2.3), lookat=(0.65, 0.62, 0.3), fovy=50)
        assets.add_camera(root, "view", pos=(2.0, -1.7, 1.9), lookat=(0.45, 0.45, 0.3), fovy=55)

    def sample_context(self, rng):
        d = rng.uniform(*GOAL_DISTANCE)
        a = rng.uniform(*GOAL_ANGLE)
        return {"goal": PUCK_START[:2] + polar(d, a)}

    def task_state(self):
        return [assets.TABLE_HEIGHT]

    def panda_placement(self):
        return {"base_pos": (-0.6, -0.3, 0.0), "base_yaw": 0.4}

    # --- skill chain (issue 6): the PhyPlan agent's prediction of where the puck stops -------------------------------
    @staticmethod
    def skill_rollout(state, actions, skills):
        """Predicted resting xy of the puck for a batch of actions, from learnt skills: swing -> hit -> slide.

        Args:
            state: the state observation as a torch tensor ``(n_state,)`` (names in ``env.state_names``).
            actions: ``(N, 2)`` float32 tensor of ``(phi, theta)``.
            skills: an object with skill models ``swing``, ``hit``, ``slide`` (see :mod:`phyplan_agents.skills`).

        Returns:
            ``(N, 2)`` predicted xy (m) where the puck comes to rest.

        The bob, released at theta, reaches the bottom of its arc at the puck (swing: first theta = 0, speed =
        |omega| * l); it hits the puck (hit: bob 0.5 kg, puck 0.05 kg), which slides along phi on the table until
        its speed crosses 0 (slide).
        """
        import torch  # imported here: the envs themselves do not need torch

        from phyplan_agents.phyplan import queries as q

        phi, theta = actions[:, 0], actions[:, 1]
        start = state[2:4]                                   # object_x, object_y
        v_bob = q.swing_bottom_speed(skills.swing, theta)
        v_puck = q.hit_speed(skills.hit, assets.BOB_MASS, assets.PUCK_MASS, v_bob)
        reach = q.slide_stop(skills.slide, v_puck)
        return start + reach[:, None] * torch.stack([torch.cos(phi), torch.sin(phi)], dim=1)
