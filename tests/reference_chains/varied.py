"""The hidden-physics tasks' skill chains: the nominal chains with parameter-conditioned skills.

On ``PhyPlan/<Task>Varied-v0`` the bob mass, the bob-object restitution, the puck-table friction (Slide, Bridge)
and the ball-incline restitution (Bounce) change per context (:mod:`phyplan_envs.hidden_physics`). These chains
predict the outcome *for given values* of those parameters: each row of their ``actions`` is the task's action
followed by the task's hidden parameters in their declared order (the env package's declaration,
:func:`phyplan_envs.hidden_physics.parameter_names`), so one batched call can score many actions
under one physics (planning) or a few actions under many candidate physics (system identification, see
:mod:`phyplan_agents.phyplan.sysid`).

Skills (:mod:`phyplan_agents.skills`): ``swing`` and ``throw`` as in the nominal chains (gravity and the rig do not
change), and the conditioned ``hit_cond`` (gain over the ideal collision, so the chain computes
``ideal_hit_speed * gain``), ``slide_cond`` (friction an input of the PINN) and ``bounce_cond`` (deviation from the
ideal reflection, so the chain adds :func:`~phyplan_envs.skill_scenes.bounce_cond.ideal_bounce`).
"""
from __future__ import annotations

import torch

from phyplan_envs.hidden_physics import PAD_RADIUS
from phyplan_envs.skill_scenes.bounce_cond import ideal_bounce
from phyplan_envs.skill_scenes.hit_cond import ideal_hit_speed

from phyplan_agents.phyplan import queries as q

LAUNCH_SKILLS = ("swing", "hit_cond", "throw")
SLIDE_SKILLS = ("swing", "hit_cond", "slide_cond")
BOUNCE_SKILLS = ("throw", "bounce_cond", "throw")
BRIDGE_SKILLS = ("swing", "hit_cond", "slide_cond", "throw")


def _hit(skills, bob_mass, m2, restitution, friction, v_bob):
    """Speed of the struck object: the ideal collision times the learnt gain."""
    n = v_bob.shape[0]
    cols = [torch.as_tensor(c, dtype=torch.float32).expand(n) for c in (bob_mass, m2, restitution, friction)]
    gain = q._predict(skills.hit_cond, torch.stack(cols + [v_bob], dim=1))[:, 0]
    return gain * ideal_hit_speed(cols[0], cols[1], cols[2], v_bob)


def _direction(phi):
    return torch.stack([torch.cos(phi), torch.sin(phi)], dim=1)


def launch(state, rows, skills, facts):
    """Launch-varied: swing -> hit_cond -> throw. ``rows``: ``(phi, theta, bob_mass, restitution)``."""
    phi, theta, m1, e = rows[:, 0], rows[:, 1], rows[:, 2], rows[:, 3]
    start = state[2:5]
    v_bob = q.swing_bottom_speed(skills.swing, theta, facts.pendulum_length)
    v_ball = _hit(skills, m1, facts.ball_mass, e, 0.0, v_bob)
    reach = q.throw_landing(skills.throw, v_ball, 0.0, start[2] - facts.landing_height).y[:, 0]
    return start[:2] + reach[:, None] * _direction(phi)


def slide(state, rows, skills, facts):
    """Slide-varied: swing -> hit_cond -> slide_cond. ``rows``: ``(phi, theta, bob_mass, restitution, friction)``.

    The puck crosses its frictionless launch pad (radius ``PAD_RADIUS``) at its launch speed, then slides."""
    phi, theta, m1, e, mu = (rows[:, i] for i in range(5))
    start = state[2:4]
    v_bob = q.swing_bottom_speed(skills.swing, theta, facts.pendulum_length)
    v_puck = _hit(skills, m1, facts.puck_mass, e, mu, v_bob)
    reach = PAD_RADIUS + q.slide_stop(skills.slide_cond, v_puck, condition=mu[:, None])
    return start + reach[:, None] * _direction(phi)


def bounce(state, rows, skills, facts):
    """Bounce-varied: throw (the fall) -> bounce_cond -> throw. ``rows``: ``(wedge_yaw, drop_height, restitution)``."""
    yaw, height, e = rows[:, 0], rows[:, 1], rows[:, 2]
    wedge_xy, impact_z = state[5:7], state[7]
    zero = torch.zeros_like(yaw)
    fall = q.throw_landing(skills.throw, zero, zero, height - impact_z)
    v_in = fall.y[:, 2]
    angle = torch.full_like(yaw, facts.wedge_angle)
    dv = q._predict(skills.bounce_cond, torch.stack([e, angle, v_in, zero], dim=1))
    v_ver, v_hor = ideal_bounce(e, angle, v_in, zero)
    reach = q.throw_landing(skills.throw, v_hor + dv[:, 1], v_ver + dv[:, 0],
                            impact_z - facts.landing_height).y[:, 0]
    return wedge_xy + reach[:, None] * _direction(yaw)


def bridge(state, rows, skills, facts):
    """Bridge-varied: swing -> hit_cond -> slide_cond (table, then plank) -> throw, as the nominal Bridge chain.
    ``rows``: ``(phi, theta, bridge_yaw, bob_mass, restitution, friction)``. The slide starts at the pad's edge."""
    phi, theta, yaw, m1, e, mu = (rows[:, i] for i in range(6))
    start = state[2:5]
    radius, height, length, half_w = state[5], state[6], state[7], state[8] / 2
    v_bob = q.swing_bottom_speed(skills.swing, theta, facts.pendulum_length)
    v0 = _hit(skills, m1, facts.puck_mass, e, mu, v_bob)
    cos_d = torch.cos(phi - yaw).clamp(min=1e-6)
    sin_d = torch.sin(phi - yaw).abs().clamp(min=1e-6)
    onto_plank = radius * sin_d <= half_w
    edge = torch.where(onto_plank, torch.minimum((radius + length) / cos_d, half_w / sin_d), radius.expand_as(phi))
    ev = q.slide_until(skills.slide_cond, v0, edge - PAD_RADIUS, condition=mu[:, None])
    top = torch.where(onto_plank, height - facts.bridge_drop, height.expand_as(phi)) + facts.puck_half_height
    fly = q.throw_landing(skills.throw, ev.y[:, 1].clamp(min=0.0), 0.0, top - facts.landing_height).y[:, 0]
    dist = torch.where(ev.valid, edge + fly, PAD_RADIUS + ev.y[:, 0])
    return start[:2] + dist[:, None] * _direction(phi)
