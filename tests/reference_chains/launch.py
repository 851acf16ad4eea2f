"""Launch's skill chain: swing -> hit -> throw, the predicted landing xy of the ball."""
from __future__ import annotations

import torch

from phyplan_agents.phyplan import queries as q

SKILLS = ("swing", "hit", "throw")


def rollout(state, actions, skills, facts):
    """Predicted landing xy of the ball for a batch of actions, from learnt skills: swing -> hit -> throw.

    Args:
        state: the state observation as a torch tensor ``(n_state,)`` (names in ``env.state_names``).
        actions: ``(N, 2)`` float32 tensor of ``(phi, theta)``.
        skills: an object with skill models ``swing``, ``hit``, ``throw`` (see :mod:`phyplan_agents.skills`).
        facts: the task's physical facts (:class:`phyplan_envs.tasks.launch.LaunchFacts`).

    Returns:
        ``(N, 2)`` predicted xy (m) where the ball's centre falls through ``facts.landing_height``.

    The bob, released at theta, reaches the bottom of its arc at the ball's height (swing: first theta = 0,
    speed = |omega| * pendulum_length); it hits the ball (hit: ``facts.bob_mass``, ``facts.ball_mass``), which
    leaves the pedestal top horizontally along phi (throw with v_ver = 0) and lands when it has dropped from its
    start height to ``landing_height``.
    """
    phi, theta = actions[:, 0], actions[:, 1]
    start = state[2:5]                                   # object_x, object_y, object_z
    v_bob = q.swing_bottom_speed(skills.swing, theta, facts.pendulum_length)
    v_ball = q.hit_speed(skills.hit, facts.bob_mass, facts.ball_mass, v_bob)
    drop = start[2] - facts.landing_height
    reach = q.throw_landing(skills.throw, v_ball, 0.0, drop).y[:, 0]
    return start[:2] + reach[:, None] * torch.stack([torch.cos(phi), torch.sin(phi)], dim=1)
