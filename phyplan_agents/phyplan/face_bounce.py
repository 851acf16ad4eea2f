"""Which skill answers an object's arrival at a face of the scene, and what it gives back (used by
:mod:`phyplan_agents.phyplan.rollout`; the order of the skills is stated in :mod:`phyplan_agents.phyplan.composer`).

Every function takes float32 tensors of R arrivals: ``v_in`` (R, 3) world velocities, ``normal`` (R, 3) the face's
outward normals, ``e`` (R,) the contact's restitution, and the face (:class:`phyplan_envs.description.Face`) whose
contact model picks the nominal or the conditioned skills.
"""
from __future__ import annotations

import math

import torch

from phyplan_envs.skill_scenes.bounce_cond import ideal_bounce

from . import queries as q

ACROSS_TOL = 1e-3      # m/s: an arrival with less speed across the face's downslope plane is "in the plane"
GRAZING = math.radians(10.0)   # rad: an arrival this close to a low-restitution face's plane settles on it (the
                               # general bounces' domain ends 5 degrees from the plane)
RANGE_TOL = 1e-6       # a skill input this far outside its training range still counts as inside (float32 rounding)


def in_ranges(model, x: torch.Tensor) -> torch.Tensor:
    """Rows of ``x`` inside a skill model's training ranges (its spec), all inputs but none of time."""
    spec = getattr(model, "spec", None)
    if spec is None:
        return torch.ones(x.shape[0], dtype=torch.bool)
    ok = torch.ones(x.shape[0], dtype=torch.bool)
    for k, (lo, hi) in enumerate(spec.ranges[:x.shape[1]]):
        ok &= (x[:, k] >= lo - RANGE_TOL) & (x[:, k] <= hi + RANGE_TOL)
    return ok


IMPACT_CONTACTS = ("impact_pair", "exact_impact")   # any restitution: the conditioned skills answer them


def conditioned(face) -> bool:
    """Whether the face's contact is a calibrated pair or an exact impact of any restitution (the conditioned
    skills answer it)."""
    return face.contact in IMPACT_CONTACTS


def grazing_low(skills, face, v_in: torch.Tensor, normal: torch.Tensor, e: torch.Tensor) -> torch.Tensor:
    """Rows whose arrival is grazing (within :data:`GRAZING` of the face's plane) at a face whose restitution is
    below the general bounce skill's domain (a low-restitution face: the object stays on it and glides)."""
    general = getattr(skills, "bounce_general_cond" if conditioned(face) else "bounce_general", None)
    spec = getattr(general, "spec", None)
    if spec is None or getattr(skills, "glide", None) is None:
        return torch.zeros(len(e), dtype=torch.bool)
    low = e < spec.ranges[0][0]
    towards = -(v_in * normal).sum(dim=1)
    return low & (towards < math.sin(GRAZING) * v_in.norm(dim=1).clamp(min=1e-9))


def face_bounce(skills, face, v_in: torch.Tensor, normal: torch.Tensor, e: torch.Tensor) -> torch.Tensor:
    """Outgoing world velocities (R, 3) of arrivals ``v_in`` at a face (NaN where no skill's domain holds): the
    downslope-plane bounce (``bounce`` / ``bounce_cond``) for an arrival in the face's downslope plane, else the
    most specific general bounce (``bounce_general``, ``bounce_general_fast`` for faster arrivals,
    ``bounce_general_low``, ``bounce_wall``, or their conditioned twins) whose domain holds it."""
    from phyplan_agents.skills.bounce_general import GeneralBounce, incline_frame

    out = torch.full_like(v_in, float("nan"))
    flat = normal[:, 2].abs() > 1 - 1e-6        # a horizontal contact plane: not a bounce the skills know
    if flat.any():
        if not flat.all():
            out[~flat] = face_bounce(skills, face, v_in[~flat], normal[~flat], e[~flat])
        return out
    frame = incline_frame(normal.double()).float()          # rows: down, across, normal
    angle = torch.arccos(normal[:, 2].clamp(-1.0, 1.0))
    down_h = frame[:, 0, :2] / frame[:, 0, :2].norm(dim=1, keepdim=True).clamp(min=1e-9)
    across_h = torch.stack([-down_h[:, 1], down_h[:, 0]], dim=1)
    v_hor = (v_in[:, :2] * down_h).sum(dim=1)
    v_across = (v_in[:, :2] * across_h).sum(dim=1)
    cond = conditioned(face)
    vertical = skills.bounce_cond if cond else skills.bounce
    x = torch.stack([e, angle, v_in[:, 2], v_hor], dim=1)
    exact = face.contact == "exact_impact"     # the general bounce off exact impacts answers every arrival
    planar = (v_across.abs() < ACROSS_TOL) & in_ranges(vertical, x) & (not exact)
    if planar.any():
        pv = q._predict(vertical, x[planar])
        if cond:
            iv, ih = ideal_bounce(x[planar, 0], x[planar, 1], x[planar, 2], x[planar, 3])
            pv = torch.stack([iv + pv[:, 0], ih + pv[:, 1]], dim=1)
        out[planar] = torch.cat([pv[:, 1:2] * down_h[planar], pv[:, 0:1]], dim=1)
    rest = ~planar
    names = (("bounce_general_exact_cond",) if exact
             else ("bounce_general_cond", "bounce_general_low_cond", "bounce_wall_cond") if cond
             else ("bounce_general", "bounce_general_fast", "bounce_general_low", "bounce_wall"))
    for name in names:                     # the most specific general bounce whose domain holds the arrival
        model = getattr(skills, name, None)
        if model is None or not rest.any():
            continue
        sel = rest.nonzero()[:, 0]
        ok, out_ok = GeneralBounce(model).predict_in_domain(v_in[sel].double(), normal[sel].double(),
                                                           e[sel].double())
        out[sel[ok]] = out_ok
        rest[sel[ok]] = False
    return out
