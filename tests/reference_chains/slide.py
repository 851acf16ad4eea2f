"""Slide's skill chain: swing -> hit -> slide, the predicted resting xy of the puck."""
from __future__ import annotations

import torch

from phyplan_agents.phyplan import queries as q

SKILLS = ("swing", "hit", "slide")


def rollout(state, actions, skills, facts):
    """Predicted resting xy of the puck for a batch of actions, from learnt skills: swing -> hit -> slide.

    Args:
        state: the state observation as a torch tensor ``(n_state,)`` (names in ``env.state_names``).
        actions: ``(N, 2)`` float32 tensor of ``(phi, theta)``.
        skills: an object with skill models ``swing``, ``hit``, ``slide`` (see :mod:`phyplan_agents.skills`).
        facts: the task's physical facts (:class:`phyplan_envs.tasks.slide.SlideFacts`).

    Returns:
        ``(N, 2)`` predicted xy (m) where the puck comes to rest.

    The bob, released at theta, reaches the bottom of its arc at the puck (swing: first theta = 0, speed =
    |omega| * pendulum_length); it hits the puck (hit: ``facts.bob_mass``, ``facts.puck_mass``), which slides along
    phi on the table until its speed crosses 0 (slide).
    """
    phi, theta = actions[:, 0], actions[:, 1]
    start = state[2:4]                                   # object_x, object_y
    v_bob = q.swing_bottom_speed(skills.swing, theta, facts.pendulum_length)
    v_puck = q.hit_speed(skills.hit, facts.bob_mass, facts.puck_mass, v_bob)
    reach = q.slide_stop(skills.slide, v_puck)
    return start + reach[:, None] * torch.stack([torch.cos(phi), torch.sin(phi)], dim=1)
