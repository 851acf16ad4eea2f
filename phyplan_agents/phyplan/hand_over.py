"""The hit's physical hand-over: where a ball hit off a frictionless top starts its flight, and at what velocity.

A ball hit off the pedestal (or pushed off Paddles' shelf) flies from its physical state once it is free, not
from its resting position at the hit skill's outcome-equivalent speed, which is exact only at the landing height
(:mod:`phyplan_envs.skill_scenes.hit_free`). Three skills record that state, each at its own plane out along the
swing (:data:`~phyplan_envs.skill_scenes.hit_free.REFERENCE`):

* ``hit_free`` (nominal hits of 1.0-2.7 m/s bob speed off the pedestal, at 0.115 m);
* ``hit_free_slow`` (slow hits and pushes of 0.2-1.05 m/s off tops whose edge is 1.5-3.5 cm ahead, Paddles'
  shelf among them, at 0.075 m), where ``hit_free``'s domain does not hold the row;
* ``hit_free_cond`` (the varied physics' hits; it extrapolates, as ``hit_cond`` does).

The composed rollout (:meth:`phyplan_agents.phyplan.rollout.Rollout.free_from_pedestal`) asks :func:`free_states`
for the rows whose ball flies off such a top; a row outside every nominal skill's domain keeps the
outcome-equivalent speed.
"""
from __future__ import annotations

from typing import NamedTuple

import torch

from phyplan_envs.skill_scenes import hit_free
from phyplan_envs.skill_scenes.hit_cond import ideal_hit_speed

from . import queries as q
from .face_bounce import in_ranges


class FreeStates(NamedTuple):
    """Per row of the query: whether a skill answered it (``ok``), and if so how far out along the swing the state
    is (``reach``, m), its height above the resting position (``dz``, m) and its velocity along the swing and
    upwards (``vh``, ``vz``, m/s)."""

    ok: torch.Tensor
    reach: torch.Tensor
    dz: torch.Tensor
    vh: torch.Tensor
    vz: torch.Tensor


def free_states(skills, x: torch.Tensor, conditioned: bool, ball_mass: float) -> FreeStates:
    """The free states of rows ``x`` (R, 4): ``(m1, m2, v_init, edge)`` for the nominal skills, ``(bob_mass,
    restitution, v_init, edge)`` with ``conditioned`` (``hit_free_cond``; ``ball_mass`` its ideal hit's)."""
    n = x.shape[0]
    ok = torch.zeros(n, dtype=torch.bool)
    reach, dz, vh, vz = (torch.zeros(n) for _ in range(4))
    if conditioned:
        skill = getattr(skills, "hit_free_cond", None)
        if skill is None or n == 0:
            return FreeStates(ok, reach, dz, vh, vz)
        y = q._predict(skill, x)
        vh = y[:, 0] * ideal_hit_speed(x[:, 0], ball_mass, x[:, 1], x[:, 2])
        dz, vz = hit_free.from_excess(vh, y[:, 1], y[:, 2])
        reach = torch.full((n,), hit_free.REFERENCE["hit_free_cond"])
        return FreeStates(torch.ones(n, dtype=torch.bool), reach, dz, vh, vz)
    for name in ("hit_free", "hit_free_slow"):
        skill = getattr(skills, name, None)
        if skill is None:
            continue
        rows = (~ok & in_ranges(skill, x)).nonzero()[:, 0]
        if len(rows) == 0:
            continue
        y = q._predict(skill, x[rows])
        if name == "hit_free":
            dz[rows], vh[rows], vz[rows] = y[:, 0], y[:, 1], y[:, 2]
        else:                              # relative to a ball that left its start horizontally
            vh[rows] = y[:, 0]
            dz[rows], vz[rows] = hit_free.from_excess(y[:, 0], y[:, 1], y[:, 2], hit_free.D_SLOW)
        reach[rows] = hit_free.REFERENCE[name]
        ok[rows] = True
    return FreeStates(ok, reach, dz, vh, vz)
