"""Governing equations of the physics-informed skills (the paper's Table 2) as residuals on collocation points.

Time derivatives of the network's outputs come from autograd (``torch.autograd.grad`` with ``create_graph=True``,
so the residual loss can be minimised). Each residual is expressed in the network's normalised units: a residual
of the k-th time derivative of output j is multiplied by ``T^k / s_j`` (T the half-range of the time input, s_j the
output's normalisation scale), so the physics loss is commensurate with the data loss (MSE of normalised outputs).

Besides Table 2's equations each skill's residual contains the kinematic link between its position and velocity
outputs (``theta' = omega``, ``x' = v``, ``y' = v_ver``: Table 2 states both forms of each equation, which presumes
it) and the initial conditions at ``t = 0`` (``theta = theta_init, omega = 0``; ``x = 0, v = v_init``;
``x = y = 0, v_ver = v_ver_init``), evaluated on separate initial-condition points.

===========  ===========================================================================
skill        equations (g = assets.GRAVITY; l = the rig's equivalent pendulum length)
===========  ===========================================================================
swing        theta'' + (g/l) sin(theta) = 0,  omega' + (g/l) sin(theta) = 0,  theta' - omega = 0
slide        x'' + mu g = 0,  v' + mu g = 0,  x' - v = 0        (mu learnt)
slide_cond   the same with mu = the friction input (the hidden-physics track: no learnt constant)
throw        v_ver' + g = 0,  y'' + g = 0,  x' - v_hor = 0,  y' - v_ver = 0
swing_wide   as swing;  throw_wide, throw_fast: as throw (the Paddles task's and bouncing paddles' variants)
glide        s_down'' - g sin(a) = 0,  v_down' - g sin(a) = 0,  s_down' - v_down = 0,
             s_across'' = 0,  s_across' - v_across0 = 0      (a the incline angle: a frictionless face)
===========  ===========================================================================

Initial conditions of glide: ``s_down = s_across = 0, v_down = v_down0``.
"""
from __future__ import annotations

import torch

from phyplan_envs import assets
from phyplan_envs.skill_scenes import pendulum_equivalent_length

from .models import SkillModel


def physics_constants(skill: str) -> dict[str, float]:
    """Known constants of a skill's equation (stored in the model's metadata)."""
    if skill in ("swing", "swing_wide"):
        return {"g": assets.GRAVITY, "l": pendulum_equivalent_length()}
    if skill in ("slide", "throw", "slide_cond", "throw_wide", "throw_fast", "glide"):
        return {"g": assets.GRAVITY}
    return {}


def _dt(y: torch.Tensor, x: torch.Tensor, ti: int) -> torch.Tensor:
    """d y / d x[:, ti] for a (N,) output y of inputs x (N, n_in), keeping the graph."""
    (g,) = torch.autograd.grad(y.sum(), x, create_graph=True)
    return g[:, ti]


def residuals(model: SkillModel, x: torch.Tensor) -> list[torch.Tensor]:
    """Residuals of the governing equations at collocation points ``x`` (N, n_in), physical units in,
    normalised units out (see the module docstring). Returns a list of (N,) tensors."""
    skill = model.skill
    ti = model.spec.time_input
    x = x.detach().requires_grad_(True)
    y = model(x)
    T = model.in_scale[ti]
    s = model.out_scale
    if skill in ("swing", "swing_wide"):
        c = assets.GRAVITY / pendulum_equivalent_length()
        th, om = y[:, 0], y[:, 1]
        th_t = _dt(th, x, ti)
        th_tt = _dt(th_t, x, ti)
        om_t = _dt(om, x, ti)
        return [(th_tt + c * torch.sin(th)) * (T * T / s[0]),
                (om_t + c * torch.sin(th)) * (T / s[1]),
                (th_t - om) * (T / s[0])]
    if skill in ("slide", "slide_cond"):
        # slide: mu is a learnt constant; slide_cond: the friction is the first input (a deceleration per row)
        a = model.phys["mu"] * assets.GRAVITY if skill == "slide" else x[:, 0] * assets.GRAVITY
        xx, v = y[:, 0], y[:, 1]
        x_t = _dt(xx, x, ti)
        x_tt = _dt(x_t, x, ti)
        v_t = _dt(v, x, ti)
        return [(x_tt + a) * (T * T / s[0]),
                (v_t + a) * (T / s[1]),
                (x_t - v) * (T / s[0])]
    if skill in ("throw", "throw_wide", "throw_fast"):
        g = assets.GRAVITY
        xx, yy, vv = y[:, 0], y[:, 1], y[:, 2]
        x_t = _dt(xx, x, ti)
        y_t = _dt(yy, x, ti)
        y_tt = _dt(y_t, x, ti)
        vv_t = _dt(vv, x, ti)
        return [(vv_t + g) * (T / s[2]),
                (y_tt + g) * (T * T / s[1]),
                (x_t - x[:, 0]) * (T / s[0]),
                (y_t - vv) * (T / s[1])]
    if skill == "glide":                             # inputs (incline_angle, v_down0, v_across0, t)
        a = assets.GRAVITY * torch.sin(x[:, 0])
        sd, sa, vd = y[:, 0], y[:, 1], y[:, 2]
        sd_t = _dt(sd, x, ti)
        sd_tt = _dt(sd_t, x, ti)
        sa_t = _dt(sa, x, ti)
        sa_tt = _dt(sa_t, x, ti)
        vd_t = _dt(vd, x, ti)
        return [(sd_tt - a) * (T * T / s[0]),
                (vd_t - a) * (T / s[2]),
                (sd_t - vd) * (T / s[0]),
                sa_tt * (T * T / s[1]),
                (sa_t - x[:, 2]) * (T / s[1])]
    raise ValueError(f"skill {skill!r} has no governing equation (Table 2): it is data-only")


def initial_residuals(model: SkillModel, x0: torch.Tensor) -> list[torch.Tensor]:
    """Initial-condition residuals at points ``x0`` whose time input is 0 (normalised units)."""
    y = model(x0)
    s = model.out_scale
    if model.skill in ("swing", "swing_wide"):
        return [(y[:, 0] - x0[:, 0]) / s[0], y[:, 1] / s[1]]
    if model.skill == "slide":
        return [y[:, 0] / s[0], (y[:, 1] - x0[:, 0]) / s[1]]
    if model.skill == "slide_cond":                  # inputs (friction, v_init, t)
        return [y[:, 0] / s[0], (y[:, 1] - x0[:, 1]) / s[1]]
    if model.skill in ("throw", "throw_wide", "throw_fast"):
        return [y[:, 0] / s[0], y[:, 1] / s[1], (y[:, 2] - x0[:, 1]) / s[2]]
    if model.skill == "glide":                       # s_down = s_across = 0, v_down = v_down0
        return [y[:, 0] / s[0], y[:, 1] / s[1], (y[:, 2] - x0[:, 1]) / s[2]]
    raise ValueError(f"skill {model.skill!r} has no initial conditions: it is data-only")
