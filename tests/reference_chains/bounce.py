"""Bounce's skill chain: throw (free fall onto the incline) -> bounce -> throw (to the ground), the landing xy."""
from __future__ import annotations

import torch

from phyplan_agents.phyplan import queries as q

SKILLS = ("throw", "bounce", "throw")


def rollout(state, actions, skills, facts):
    """Predicted landing xy of the ball for a batch of actions, from learnt skills: throw -> bounce -> throw.

    Args:
        state: the state observation as a torch tensor ``(n_state,)`` (names in ``env.state_names``).
        actions: ``(N, 2)`` float32 tensor of ``(wedge_yaw, drop_height)``.
        skills: an object with skill models ``throw`` and ``bounce`` (see :mod:`phyplan_agents.skills`).
        facts: the task's physical facts (:class:`phyplan_envs.tasks.bounce.BounceFacts`).

    Returns:
        ``(N, 2)`` predicted xy (m) where the ball's centre falls through ``facts.landing_height``.

    The ball falls from rest at ``drop_height`` to ``impact_z`` (throw with zero initial velocity: the vertical
    speed there); it bounces off the incline (bounce: the incline's nominal restitution
    ``facts.incline_restitution``, ``facts.wedge_angle``, the incoming vertical speed, no horizontal speed), and flies
    from the impact point above the wedge's yaw axis along ``wedge_yaw`` (throw from ``impact_z`` down to
    ``landing_height``).
    """
    yaw, height = actions[:, 0], actions[:, 1]
    wedge_xy, impact_z = state[5:7], state[7]             # wedge_x, wedge_y, impact_z
    zero = torch.zeros_like(yaw)
    fall = q.throw_landing(skills.throw, zero, zero, height - impact_z)
    e = torch.full_like(yaw, facts.incline_restitution)
    out = skills.bounce.predict(torch.stack([e, torch.full_like(yaw, facts.wedge_angle), fall.y[:, 2], zero],
                                            dim=1))
    reach = q.throw_landing(skills.throw, out[:, 1], out[:, 0], impact_z - facts.landing_height).y[:, 0]
    return wedge_xy + reach[:, None] * torch.stack([torch.cos(yaw), torch.sin(yaw)], dim=1)
