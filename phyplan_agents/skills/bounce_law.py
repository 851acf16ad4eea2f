"""The reflection law of the general-incidence bounce skills, as a PINN's physics residual.

Inputs ``(e, incline_angle, v_down, v_across, v_normal)`` and outputs ``(v_down, v_across, v_normal)`` in the
incline frame (:mod:`phyplan_envs.skill_scenes.bounce_general`). The law the MuJoCo data follow (measured in
``docs/skills.md``, *General-incidence bounce*)::

    v_out_across = v_in_across                                  (condim 1: no friction, exact in the data)
    v_out_down   = v_in_down + g sin(incline_angle) tau          (gravity along the face during the contact)
    v_out_normal = -(e + beta (1 - e)) v_in_normal               (the contact's effective restitution)

``tau`` (the contact's duration, ~7 ms: half a period of the K = 2e5 spring) and ``beta`` (how far the effective
restitution, averaged over the arrival phase, exceeds the set one, per unit of ``1 - e``) are the unknown
parameters: the PINN learns them as the paper's slide PINN learns mu (``contact_ms``, ``restitution_excess``). With
``tau = beta = 0`` it is the textbook frictionless reflection (:func:`textbook`), the analytic reference.

The residuals are algebraic (no time input, so no autograd derivatives) and in the network's normalised units
(divided by the output scales), as those of :mod:`.physics`. Collocation points follow the data's domain
(:func:`collocation`): speeds and directions as the scene draws them, the restitution over the whole model domain
(for ``bounce_general_cond`` the hull of the track's training and test spaces, where the data cover only the
training space).
"""
from __future__ import annotations

import math

import numpy as np
import torch

from phyplan_envs import assets
from phyplan_envs.skill_scenes import DATA_SPECS
from phyplan_envs.skill_scenes import bounce_general as scene
from phyplan_envs.skill_scenes import bounce_general_low as low_scene

LAW_SKILLS = ("bounce_general", "bounce_general_cond")       # their contract entries: .contract.SKILLS
# the Paddles task's low-restitution bounces at 0.5 ms (phyplan_envs.skill_scenes.bounce_general_low): the same law
LAW_SKILLS += ("bounce_general_low", "bounce_general_low_cond")
# the bounces off steep faces and walls (80-90 degrees): the same scenes and law
LAW_SKILLS += ("bounce_wall", "bounce_wall_cond", "bounce_general_fast")
# the bounce off faces with exact impacts (phyplan_envs.skill_scenes.bounce_exact): the same law, tau ~ one step
LAW_SKILLS += ("bounce_general_exact_cond",)
SPEED = {"bounce_general": scene.SPEED, "bounce_general_cond": scene.SPEED,
         "bounce_general_low": low_scene.SPEED_LOW, "bounce_general_low_cond": low_scene.SPEED_LOW,
         "bounce_wall": scene.SPEED, "bounce_wall_cond": scene.SPEED, "bounce_general_fast": scene.SPEED_FAST,
         "bounce_general_exact_cond": low_scene.SPEED_LOW}
"""The incoming speed range (m/s) of each law skill's data (the speed is not an input column)."""
LEARNT = {"contact_ms": 5.0, "restitution_excess": 0.0}   # initial values (the data: ~6.9 ms, ~0.03)


def law(x, contact_ms, restitution_excess):
    """Outgoing velocities (N, 3) of the law for inputs ``x`` (N, 5) (torch tensors or numpy arrays; ``contact_ms``
    in milliseconds)."""
    e, angle, vd, va, vn = (x[:, i] for i in range(5))
    is_torch = isinstance(x, torch.Tensor)
    sin = torch.sin(angle) if is_torch else np.sin(angle)
    eff = e + restitution_excess * (1 - e)
    out = [vd + assets.GRAVITY * sin * (contact_ms * 1e-3), va, -eff * vn]
    return torch.stack(out, dim=1) if is_torch else np.stack(out, axis=1)


def textbook(x):
    """The frictionless reflection without gravity during the contact: normal reversed and scaled by ``e``,
    tangential kept (the analytic reference)."""
    return law(x, 0.0, 0.0)


def residuals(model, x: torch.Tensor) -> list[torch.Tensor]:
    """The law's residuals (one (N,) tensor per output, normalised units) of ``model`` at points ``x`` (N, 5)."""
    y = model(x)
    ref = law(x, model.phys["contact_ms"], model.phys["restitution_excess"])
    return [(y[:, j] - ref[:, j]) / model.out_scale[j] for j in range(3)]


def collocation(skill: str, n: int, gen: torch.Generator) -> torch.Tensor:
    """``n`` points (N, 5) of the skill's domain from ``gen``: restitution and angle uniform over the spec's ranges,
    the incoming velocity as :func:`phyplan_envs.skill_scenes.bounce_general.draw_velocity` draws it (speed uniform,
    direction uniform within the largest incidence, at least the least normal speed)."""
    ranges = DATA_SPECS[skill].ranges
    cmin = math.cos(scene.MAX_INCIDENCE)
    speed = SPEED[skill]
    rows, have = [], 0
    while have < n:
        m = 2 * (n - have) + 16
        u = torch.rand(m, 5, generator=gen)
        s = speed[0] + (speed[1] - speed[0]) * u[:, 2]
        c = cmin + (1 - cmin) * u[:, 3]
        psi = 2 * math.pi * u[:, 4]
        keep = s * c >= scene.MIN_NORMAL_SPEED
        r = s * (1 - c * c).clamp_min(0).sqrt()
        pts = torch.stack([ranges[0][0] + (ranges[0][1] - ranges[0][0]) * u[:, 0],
                           ranges[1][0] + (ranges[1][1] - ranges[1][0]) * u[:, 1],
                           r * psi.cos(), r * psi.sin(), -s * c], dim=1)[keep]
        rows.append(pts)
        have += len(pts)
    return torch.cat(rows)[:n]
