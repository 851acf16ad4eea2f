"""Bridge's skill chain: swing -> hit -> slide (table, then plank) -> throw, the predicted end xy of the puck."""
from __future__ import annotations

import torch

from phyplan_agents.phyplan import queries as q

SKILLS = ("swing", "hit", "slide", "throw")


def rollout(state, actions, skills, facts):
    """Predicted end xy of the puck for a batch of actions: swing -> hit -> slide (table, then plank) -> throw.

    Args:
        state: the state observation as a torch tensor ``(n_state,)`` (names in ``env.state_names``).
        actions: ``(N, 3)`` float32 tensor of ``(phi, theta, bridge_yaw)``.
        skills: an object with skill models ``swing``, ``hit``, ``slide``, ``throw`` (see
            :mod:`phyplan_agents.skills`).
        facts: the task's physical facts (:class:`phyplan_envs.tasks.bridge.BridgeFacts`).

    Returns:
        ``(N, 2)`` predicted xy (m): where the puck's centre falls through ``facts.landing_height``, or where it
        stops if it stops on the table or the plank.

    The bob, released at theta, hits the puck (swing: first theta = 0, speed = |omega| * pendulum_length; hit:
    ``facts.bob_mass``, ``facts.puck_mass``), which slides from the table centre along phi. It loses support where
    its centre passes an edge: the table rim (``table_radius``) if the path misses the plank, else the plank's far
    end (``table_radius + bridge_length`` along the plank) or its side edge (``bridge_width / 2`` off the plank's
    centreline), whichever comes first. The slide model gives its speed there (or the point where it stops
    before); from there it flies horizontally (throw) from the table or plank top (``facts.bridge_drop`` below the
    table's; the puck's centre ``facts.puck_half_height`` above) down to ``landing_height``. The table and plank
    sizes are read from the state vector.
    """
    phi, theta, yaw = actions[:, 0], actions[:, 1], actions[:, 2]
    start = state[2:5]                                    # object_x, object_y, object_z
    radius, height, length, half_w = state[5], state[6], state[7], state[8] / 2
    v_bob = q.swing_bottom_speed(skills.swing, theta, facts.pendulum_length)
    v0 = q.hit_speed(skills.hit, facts.bob_mass, facts.puck_mass, v_bob)
    cos_d = torch.cos(phi - yaw).clamp(min=1e-6)          # |phi - yaw| <= pi/2 for the action bounds
    sin_d = torch.sin(phi - yaw).abs().clamp(min=1e-6)
    onto_plank = radius * sin_d <= half_w                 # still on the plank's width at the rim
    edge = torch.where(onto_plank, torch.minimum((radius + length) / cos_d, half_w / sin_d),
                       radius.expand_as(phi))
    ev = q.slide_until(skills.slide, v0, edge)
    top = torch.where(onto_plank, height - facts.bridge_drop, height.expand_as(phi)) + facts.puck_half_height
    fly = q.throw_landing(skills.throw, ev.y[:, 1].clamp(min=0.0), 0.0, top - facts.landing_height).y[:, 0]
    dist = torch.where(ev.valid, edge + fly, ev.y[:, 0])
    return start[:2] + dist[:, None] * torch.stack([torch.cos(phi), torch.sin(phi)], dim=1)
