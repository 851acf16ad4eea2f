"""Where a batch of flights first meets something: the ground, a face (inside it or at its edge) or an obstacle (the
contact search of :meth:`phyplan_agents.phyplan.rollout.Rollout.fly_with`).

The ground, every face's plane and every obstacle are the events of one many-event query on the throw model
(:func:`phyplan_agents.phyplan.queries.first_events`). The ground ends a flight wherever it is crossed, so the query
stops searching a row after it. A face's plane crossed well inside the face (:data:`SURE_INSIDE`) ends the flight
too, and the query stops there as well (its ``ends``). That stop is checked: a row whose first contact comes later
than the time it was searched to (the plane was crossed outside the face after all) is searched again over the
whole range. The contacts are therefore those of the full search, at a fraction of its cost where flights meet
faces (a ball falling through paddles meets one every few tenths of a second, and the ground after seconds).
"""
from __future__ import annotations

import math
from typing import NamedTuple

import torch

from . import geometry as geo
from . import queries as q

SURE_INSIDE = 0.02     # m: a face's plane reached this far inside the face at both ends of a grid interval ends the
                       # flight there. Between two grid points the path strays from their chord by g dt^2 / 8, under
                       # 1.3 cm on the widest throw grid (0.1 s); a stop it gets wrong is searched again anyway
_TOL = 1e-6


class Contacts(NamedTuple):
    """Per row and event (column 0 the ground, then the faces, then the obstacles): the crossing time ``t``
    (n, M), the throw's outputs there ``y`` (n, M, n_out; NaN where not crossed), whether it is a contact ``ok``
    (n, M: the ground, a face inside its polygon or within the radius of it, an obstacle) and whether a face's is at
    its edge ``edge`` (n, M: outside the polygon, within the radius)."""

    t: torch.Tensor
    y: torch.Tensor
    ok: torch.Tensor
    edge: torch.Tensor


class Flight:
    """The flights of ``n`` rows from ``pos`` (n, 3) along the unit directions ``u`` (n, 2) at horizontal and
    vertical speeds ``vh``, ``vz`` (n,); ``faces``: per face its vertices (n, k, 3) and normals (n, 3); ``left``:
    per row the face a glide just left (not met again; -1: none); ``radius``: the object's; ``landing_height``:
    the ground's; ``blocks``: the obstacles' arrays picked to these rows (:func:`geometry.block_arrays`), or
    None; ``guards``: per face, how far inside its polygon a touch must be to count as inside it (m, per row (n,);
    default 0): a touch between that and the radius outside is at its edge."""

    def __init__(self, throw, pos, u, vh, vz, faces, left, radius: float, landing_height: float, blocks=None,
                 guards=None):
        self.guards = [torch.zeros(len(pos))] * len(faces) if guards is None else list(guards)
        self.throw, self.pos, self.u, self.vh, self.vz = throw, pos, u, vh, vz
        self.faces, self.left, self.r, self.landing = faces, left, radius, landing_height
        n = len(pos)
        self.n_f = len(faces)
        # every face's first vertex and normal (n, F, 3): a plane's distance needs only those
        self.first_v = torch.stack([v[:, 0] for v, _ in faces], dim=1)
        self.normals = torch.stack([nrm for _, nrm in faces], dim=1)
        self.face_no = torch.arange(self.n_f)
        self.u3 = torch.cat([u, torch.zeros(n, 1)], dim=1)
        self.up = torch.tensor([0.0, 0.0, 1.0])
        self.blocks = blocks
        if blocks is not None:
            # the obstacles a flight can meet: not one it starts on or against (a ball hit off the pedestal's top),
            # and only where its straight path in the plane passes near one (else no search for them at all)
            self.may = (self.block_gaps(pos, torch.arange(n)) > _TOL) & geo.ray_may_reach(blocks, pos, u, radius)
            if not self.may.any():
                self.blocks = None

    def at(self, y: torch.Tensor, i: torch.Tensor) -> torch.Tensor:
        """The centre (R, 3) of rows ``i`` at the throw's outputs ``y`` (R, n_out)."""
        return self.pos[i] + y[:, 0:1] * self.u3[i] + y[:, 1:2] * self.up

    def block_gaps(self, p, i):
        """(R, O): <= 0 where the object touches an obstacle (its side or its top)."""
        b = self.blocks
        return geo.block_distance(tuple(a[i] for a in b[:3]) + b[3:], p) - self.r

    def obstacle_gaps(self, p, i):
        g = self.block_gaps(p, i)
        return torch.where(self.may[i], g, torch.ones_like(g))

    def measure(self, y, t, i):
        p = self.at(y, i)
        g = geo.plane_offset(self.first_v[i], self.normals[i], p[:, None, :]) - self.r                   # (R, F)
        g = torch.where(self.left[i][:, None] == self.face_no, torch.ones_like(g), g)
        parts = [(p[:, 2] - self.landing)[:, None], g] + ([self.obstacle_gaps(p, i)] if self.blocks else [])
        return torch.cat(parts, dim=1)

    def measure_one(self, y, t, i, col):
        p = self.at(y, i)
        f = (col - 1).clamp(min=0, max=self.n_f - 1)
        g = geo.plane_offset(self.first_v[i, f], self.normals[i, f], p) - self.r
        g = torch.where(self.left[i] == f, torch.ones_like(g), g)
        g = torch.where(col == 0, p[:, 2] - self.landing, g)
        if self.blocks:
            b = (col - 1 - self.n_f).clamp(min=0)
            g = torch.where(col > self.n_f, self.obstacle_gaps(p, i).gather(1, b[:, None])[:, 0], g)
        return g

    def sure(self, y, t, i, col):
        """(R,): whether reaching face ``col - 1``'s plane next to this point (outputs ``y`` at time ``t`` of rows
        ``i``) ends the flight: the touching point is :data:`SURE_INSIDE` inside the face's polygon."""
        p = self.at(y, i)
        out = torch.zeros(len(i), dtype=torch.bool)
        for f in torch.unique(col).tolist():
            if not 1 <= f <= self.n_f:             # the ground is final anyway; an obstacle is never sure
                continue
            m = col == f
            v, nrm = self.faces[f - 1]
            im = i[m]
            out[m] = geo.inside_polygon(v[im], nrm[im], p[m] - self.r * nrm[im], margin=-SURE_INSIDE)
        return out

    def search(self, sel: torch.Tensor, t0: float, t1: float, stop_inside: bool) -> tuple[Contacts, torch.Tensor]:
        """The contacts of rows ``sel`` and how far each was searched (s; inf: the whole range)."""
        def measure(y, t, i):
            return self.measure(y, t, sel[i])

        def measure_one(y, t, i, col):
            return self.measure_one(y, t, sel[i], col)

        def ends(y, t, i, col):
            return self.sure(y, t, sel[i], col)

        x = torch.stack([self.vh[sel], self.vz[sel]], dim=1)
        found = q.first_events(self.throw, x, measure, t0, t1, final=(0,), measure_one=measure_one,
                               ends=ends if stop_inside else None)
        t_ev, crossed = found.t, found.valid
        m = t_ev.shape[1]
        # the throw's state at each crossing (only crossed events are read; the rest stay NaN)
        at = torch.cat([x.repeat_interleave(m, 0), t_ev.reshape(-1, 1)], dim=1)
        hit_rows = crossed.reshape(-1)
        y_hit = q._predict(self.throw, at[hit_rows])
        y = torch.full((len(at), y_hit.shape[1]), float("nan"))
        y[hit_rows] = y_hit
        y = y.reshape(len(sel), m, -1)
        ok = crossed.clone()
        edge = torch.zeros_like(ok)
        for f, (v, nrm) in enumerate(self.faces):    # where a face's plane was crossed: inside, at an edge, or off
            rows_f = ok[:, f + 1].nonzero()[:, 0]
            if len(rows_f) == 0:
                continue
            ri = sel[rows_f]
            at_face = self.at(y[rows_f, f + 1], ri) - self.r * nrm[ri]
            inside = geo.inside_polygon(v[ri], nrm[ri], at_face, margin=-self.guards[f][ri, None])
            near = ~inside & geo.inside_polygon(v[ri], nrm[ri], at_face, margin=self.r)
            edge[rows_f, f + 1] = near
            ok[rows_f, f + 1] = inside | near
        return Contacts(t_ev, y, ok, edge), found.horizon

    def contacts(self, t0: float, t1: float) -> Contacts:
        """Every row's contacts (the module docstring): searched with the stop inside the faces, then again over
        the whole range where the first contact comes after the time searched to."""
        c, horizon = self.search(torch.arange(len(self.pos)), t0, t1, stop_inside=True)
        first = torch.where(c.ok, c.t, torch.full_like(c.t, math.inf)).min(dim=1).values
        again = (first > horizon).nonzero()[:, 0]
        if len(again):
            d, _ = self.search(again, t0, t1, stop_inside=False)
            for full, part in zip(c, d):
                full[again] = part
        return c
