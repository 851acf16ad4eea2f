"""The general-incidence bounce skill: a ball arriving at an incline from any direction into its face, in world or
incline coordinates, with the frame conversions a skill chain needs.

>>> from phyplan_agents.skills.bounce_general import load_general_bounce, wedge_normal
>>> bounce = load_general_bounce()                       # Bounce-v0 wedge contact; physics="varied": the track's
>>> n = wedge_normal(yaw=0.7)                            # the 45 degree task wedge turned by 0.7 rad
>>> bounce.predict([[2.0, 0.0, -1.0]], n, 0.9487)        # v_in (world) -> v_out (world), m/s

The networks (:mod:`phyplan_agents.skills` models ``bounce_general`` and ``bounce_general_cond``) map the incline
frame's ``(e, incline_angle, v_down, v_across, v_normal)`` to the outgoing ``(v_down, v_across, v_normal)``; the
frame of an incline with outward normal ``n`` (:func:`incline_frame`) has rows

* ``down``: the steepest descent in the face, ``normalise(-z + n_z n)``;
* ``across``: ``n x down`` (level, so (down, across, normal) is right-handed);
* ``normal``: ``n``; the incline angle is the normal's angle from vertical, ``acos(n_z)``.

The domain (the data's, :mod:`phyplan_envs.skill_scenes.bounce_general`): speed 0.5-6 m/s, incidence within 85
degrees of the inward normal and at least 0.1 m/s towards the face, incline angle 10-80 degrees, restitution 0.8-1
(nominal physics: the solref's nominal restitution, 0.9487 for the task wedge) or 0.4-0.99 (varied physics: the
hidden restitution). :meth:`GeneralBounce.predict` refuses inputs outside it (naming the argument and the first bad
row); :meth:`GeneralBounce.in_domain` is the mask to filter a batch first.
"""
from __future__ import annotations

import math
import os

import numpy as np
import torch

from phyplan_envs import assets
from phyplan_envs.skill_scenes import bounce_general as scene
from phyplan_envs.skill_scenes import bounce_general_low as low_scene

from . import bounce_law, io
from .models import SkillModel

HORIZONTAL_TOL = 1e-9      # |n_z| above 1 - this: a horizontal face, whose downslope direction is undefined
_TOL = 1e-6                # slack on the domain's bounds (inputs computed in float32 sit on them)


def _tensor(x, name: str, last: int | None = 3) -> torch.Tensor:
    """``x`` as a real tensor (a floating tensor keeps its dtype; anything else becomes float64), checked."""
    if isinstance(x, torch.Tensor):
        t = x.detach()
        if t.is_complex() or t.dtype == torch.bool:
            raise ValueError(f"{name} must be real numbers, got dtype {t.dtype}")
        t = t if t.is_floating_point() else t.to(torch.float64)
    else:
        try:
            t = torch.as_tensor(np.asarray(x, dtype=np.float64))
        except (TypeError, ValueError) as exc:
            raise ValueError(f"{name} must be real numbers, got {type(x).__name__}: {exc}") from None
    if last is not None and (t.ndim not in (1, 2) or t.shape[-1] != last):
        raise ValueError(f"{name} must have shape ({last},) or (N, {last}), got {tuple(t.shape)}")
    if not torch.isfinite(t).all():
        raise ValueError(f"{name} has non-finite values")
    return t


def incline_frame(normal) -> torch.Tensor:
    """Rows (down, across, normal) of the incline frame(s) of outward normal(s) ``normal`` ((3,) -> (3, 3) or
    (N, 3) -> (N, 3, 3); any length, normalised here). A horizontal face (no downslope direction) is an error."""
    n = _tensor(normal, "normal").to(torch.float64)
    length = n.norm(dim=-1, keepdim=True)
    if (length == 0).any():
        raise ValueError("normal must be a non-zero vector")
    n = n / length
    z = torch.zeros_like(n)
    z[..., 2] = 1.0
    flat = n[..., 2].abs() > 1 - HORIZONTAL_TOL
    if flat.any():
        raise ValueError(f"normal {n[flat][0].tolist()} is vertical: a horizontal face has no downslope direction")
    down = -z + n[..., 2:3] * n
    down = down / down.norm(dim=-1, keepdim=True)
    across = torch.linalg.cross(n, down, dim=-1)
    return torch.stack([down, across, n], dim=-2)


def incline_angle(normal) -> torch.Tensor:
    """The incline angle(s) (rad) of outward normal(s): the normal's angle from vertical."""
    n = _tensor(normal, "normal")
    return torch.arccos((n[..., 2] / n.norm(dim=-1)).clamp(-1.0, 1.0))


def to_incline(v_world, frame) -> torch.Tensor:
    """World vector(s) ``v_world`` ((3,) or (N, 3)) in the incline frame(s) ``frame`` ((3, 3) or (N, 3, 3))."""
    v, f = _tensor(v_world, "v_world"), _frame(frame)
    return torch.einsum("...ij,...j->...i", f.to(v.dtype), v)


def from_incline(v_local, frame) -> torch.Tensor:
    """Incline-frame vector(s) ``v_local`` back in the world frame (the inverse of :func:`to_incline`)."""
    v, f = _tensor(v_local, "v_local"), _frame(frame)
    return torch.einsum("...ji,...j->...i", f.to(v.dtype), v)


def _frame(frame) -> torch.Tensor:
    f = _tensor(frame, "frame", last=None)
    if f.ndim not in (2, 3) or f.shape[-2:] != (3, 3):
        raise ValueError(f"frame must have shape (3, 3) or (N, 3, 3), got {tuple(f.shape)}")
    return f


def wedge_normal(yaw: float, angle: float = assets.WEDGE_ANGLE) -> torch.Tensor:
    """The outward normal of the suite's wedge (``assets.add_wedge``: at yaw 0 its incline falls towards +x) turned
    by ``yaw`` about the vertical, for an incline ``angle`` (default the task wedge's 45 degrees)."""
    for name, v in (("yaw", yaw), ("angle", angle)):
        if not math.isfinite(float(v)):
            raise ValueError(f"{name} must be finite, got {v!r}")
    s = math.sin(angle)
    return torch.tensor([math.cos(yaw) * s, math.sin(yaw) * s, math.cos(angle)], dtype=torch.float64)


class GeneralBounce:
    """A loaded general-bounce model with the frame conversions and the domain checks.

    Attributes: ``model`` (the :class:`~phyplan_agents.skills.SkillModel`), ``physics`` (``"nominal"`` or
    ``"varied"``), ``restitution_range``, ``angle_range`` (rad), ``speed_range`` (m/s).
    """

    def __init__(self, model: SkillModel):
        if model.skill not in bounce_law.LAW_SKILLS:
            raise ValueError(f"a general bounce needs a bounce_general model, got {model.skill!r}")
        self.model = model
        self.physics = "varied" if model.skill.endswith("_cond") else "nominal"
        self.restitution_range = tuple(model.spec.ranges[0])
        self.angle_range = tuple(model.spec.ranges[1])
        self.speed_range = bounce_law.SPEED[model.skill]     # scene.SPEED; the low-restitution skills': 0.5-9 m/s

    @property
    def kind(self) -> str:
        return self.model.kind

    @property
    def params(self) -> dict[str, float]:
        """The PINN's learnt law constants (``contact_ms``, ``restitution_excess``); empty for the NN."""
        return self.model.params

    def __repr__(self) -> str:
        extra = "".join(f", {k}={v:.4g}" for k, v in self.params.items())
        return f"GeneralBounce(physics={self.physics!r}, kind={self.kind!r}{extra})"

    # --- domain --------------------------------------------------------------------------------------------------
    def _problems(self, e: torch.Tensor, angle: torch.Tensor, v: torch.Tensor):
        """(name, mask, description) of every domain condition, for incline-frame inputs."""
        speed = v.norm(dim=-1)
        vn = -v[:, 2]
        (elo, ehi), (alo, ahi), (slo, shi) = self.restitution_range, self.angle_range, self.speed_range
        cmin = math.cos(scene.MAX_INCIDENCE)
        return [
            ("restitution", (e < elo - _TOL) | (e > ehi + _TOL), f"outside [{elo}, {ehi}]"),
            ("normal", (angle < alo - _TOL) | (angle > ahi + _TOL),
             f"incline angle outside [{math.degrees(alo):.0f}, {math.degrees(ahi):.0f}] degrees"),
            ("v_in", (speed < slo - _TOL) | (speed > shi + _TOL), f"speed outside [{slo}, {shi}] m/s"),
            ("v_in", vn <= 0, "does not move into the incline's face"),
            ("v_in", (vn < scene.MIN_NORMAL_SPEED - _TOL) | (vn < (cmin - _TOL) * speed),
             f"grazes the face (normal speed below {scene.MIN_NORMAL_SPEED} m/s or incidence beyond "
             f"{math.degrees(scene.MAX_INCIDENCE):.0f} degrees)"),
        ]

    def _inputs(self, v_in, normal, restitution, local: bool):
        v = _tensor(v_in, "v_in").to(torch.float64)
        v = v[None] if v.ndim == 1 else v
        n_rows = v.shape[0]
        if local:
            a = _tensor(normal, "incline_angle", last=None).to(torch.float64).reshape(-1)
            frame = None
            angle = a
            vl = v
        else:
            frame = incline_frame(normal).to(torch.float64)
            frame = frame[None] if frame.ndim == 2 else frame
            angle = torch.arccos(frame[:, 2, 2].clamp(-1, 1))
            vl = None
        e = _tensor(restitution, "restitution", last=None).to(torch.float64).reshape(-1)
        for name, t in (("restitution", e), ("incline_angle" if local else "normal", angle)):
            if t.shape[0] not in (1, n_rows):
                raise ValueError(f"{name} has {t.shape[0]} rows, v_in has {n_rows}")
        if frame is not None:
            frame = frame.expand(n_rows, 3, 3)
            vl = to_incline(v, frame)
        return e.expand(n_rows), angle.expand(n_rows), vl, frame

    def in_domain(self, v_in, normal, restitution) -> torch.Tensor:
        """Boolean mask (N,): rows of world-frame inputs (as :meth:`predict`) inside the skill's domain."""
        e, angle, vl, _ = self._inputs(v_in, normal, restitution, local=False)
        return self._inside(e, angle, vl)

    def _inside(self, e, angle, vl) -> torch.Tensor:
        bad = torch.zeros(len(e), dtype=torch.bool)
        for _, mask, _ in self._problems(e, angle, vl):
            bad |= mask
        return ~bad

    def _outgoing(self, e, angle, vl, frame) -> torch.Tensor:
        """The network's outgoing velocities for incline-frame inputs, back in the world frame (float32)."""
        x = torch.cat([e[:, None], angle[:, None], vl], dim=1)
        out = self.model.predict(x.to(torch.float32)).to(torch.float64)
        return from_incline(out, frame).to(torch.float32)

    def predict_in_domain(self, v_in, normal, restitution) -> tuple[torch.Tensor, torch.Tensor]:
        """``(ok, out)`` for world-frame inputs (as :meth:`predict`): the mask (N,) of rows inside the skill's domain
        (:meth:`in_domain`) and the outgoing world velocities (ok.sum(), 3) of those rows (:meth:`predict`), with
        the frames computed once."""
        e, angle, vl, frame = self._inputs(v_in, normal, restitution, local=False)
        ok = self._inside(e, angle, vl)
        if not ok.any():
            return ok, torch.zeros(0, 3)
        return ok, self._outgoing(e[ok], angle[ok], vl[ok], frame[ok])

    def _check(self, e, angle, vl) -> None:
        for name, mask, what in self._problems(e, angle, vl):
            if mask.any():
                i = int(mask.nonzero()[0])
                row = {"restitution": f"{float(e[i]):.4g}", "normal": f"{math.degrees(float(angle[i])):.2f} deg",
                       "v_in": f"{[round(float(c), 4) for c in vl[i]]} (incline frame)"}[name]
                raise ValueError(f"{name} {what}: row {i} has {row} ({int(mask.sum())} of {len(e)} rows)")

    # --- prediction ----------------------------------------------------------------------------------------------
    def predict_local(self, v_in_local, incline_angle, restitution) -> torch.Tensor:
        """Outgoing incline-frame velocities (N, 3) for incoming ones ``v_in_local`` ((3,) or (N, 3): down, across,
        normal), incline angle(s) (rad) and restitution(s) (scalars or (N,))."""
        e, angle, vl, _ = self._inputs(v_in_local, incline_angle, restitution, local=True)
        self._check(e, angle, vl)
        x = torch.cat([e[:, None], angle[:, None], vl], dim=1)
        return self.model.predict(x.to(torch.float32))

    def predict(self, v_in, normal, restitution) -> torch.Tensor:
        """Outgoing world velocities (N, 3) of a ball arriving at ``v_in`` (world, m/s; (3,) or (N, 3)) at an
        incline of outward normal ``normal`` ((3,) or (N, 3), world) with restitution ``restitution``."""
        e, angle, vl, frame = self._inputs(v_in, normal, restitution, local=False)
        self._check(e, angle, vl)
        return self._outgoing(e, angle, vl, frame)

    def textbook(self, v_in, normal, restitution) -> torch.Tensor:
        """The analytic reference in world coordinates: the frictionless reflection (normal reversed and scaled by
        ``restitution``, tangential kept), on the same domain."""
        e, angle, vl, frame = self._inputs(v_in, normal, restitution, local=False)
        self._check(e, angle, vl)
        x = torch.cat([e[:, None], angle[:, None], vl], dim=1)
        return from_incline(bounce_law.textbook(x), frame).to(torch.float32)


def load_general_bounce(physics: str = "nominal", kind: str | None = None,
                        directory: str | os.PathLike | None = None, low: bool = False) -> GeneralBounce:
    """The shipped general bounce (``physics="nominal"``: the Bounce-v0 wedge contact, ``"varied"``: the
    hidden-physics track's impact pair; ``kind`` ``"pinn"`` (default) or ``"nn"``; ``directory``: another weights
    folder; ``low=True``: the Paddles task's low-restitution skills ``bounce_general_low`` / ``_low_cond`` at
    0.5 ms). Raises :class:`~phyplan_agents.skills.SkillFileError` for missing or corrupt files."""
    scene.check_physics(physics)
    names = low_scene.SKILL_OF_PHYSICS if low else scene.SKILL_OF_PHYSICS
    return GeneralBounce(io.load(names[physics], kind, directory))


def as_array(t: torch.Tensor) -> np.ndarray:
    """A float64 numpy copy of a result (convenience for callers outside torch)."""
    return t.detach().to(torch.float64).numpy().copy()
