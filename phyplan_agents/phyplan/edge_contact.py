"""A flight that meets a face's edge or corner: the search for the contact, and the contact's normal.

The composed flight (:mod:`phyplan_agents.phyplan.rollout`) first searches the planes of the scene's faces. Where
the first plane crossing lies outside the face's polygon but within the object's radius of it, the object may touch
an edge or a corner instead. :func:`first_contacts` searches those flights again with one more event per edge of
every face that bounces (a face of restitution 0 keeps the object, and no skill knows it keeping it at an edge): the
object's centre within its radius of the edge segment. A sphere touching an edge (or a corner: a segment's end)
is pushed along the line from the closest point of the edge to its centre, as MuJoCo's contact between a sphere and
a convex mesh or box does. That line turns while the sphere rolls around the edge during the contact, so the
contact bounces like a face of its normal half-way through the contact (:data:`CONTACT_MID`, on the free path)
with the face's restitution (:func:`~phyplan_agents.phyplan.face_bounce.face_bounce`).

The composed chain's landing error on LaunchBounce's bouncing actions whose ball touches an edge, and on the others,
is printed by ``python -m benchmarks.composition --section accuracy --tasks launch-bounce``.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import torch

from phyplan_envs.skill_scenes import bounce_general as general_scene

from . import geometry as geo
from . import queries as q

NONE, GROUND, FACE, EDGE = -1, 0, 1, 2
BEFORE = 0.07          # s: the contact search starts this long before the plane crossing the flight's search found
                       # (more than that search's grid step, 62 ms)
WINDOW = 0.12          # s: and covers this long: after the crossing, 50 ms, in which a 1 m/s centre moves 5 cm, more
                       # than the diameter of the ball
CONTACT_MID = 0.0035   # s: half a contact's duration (~7 ms in the bounce skills' MuJoCo data, the spring's half
                       # period; the bounce PINN learns it as contact_ms): a sphere rolls around an edge during the
                       # contact, so the push's mean direction is the edge's normal this long after the touch
GRID_STEP = 0.005      # s: the contact search's grid step. A centre passing within 0.9 of its radius of an edge is
                       # closer than its radius for 0.87 r of its path: 17 mm for a 2 cm ball, 5 ms at 3.5 m/s


@dataclass
class NearEdge:
    """What :func:`near_edges` found for R flights: ``column`` the event met (0 the ground, f + 1 face f's plane or
    one of its edges, -1 nothing in the window), ``edge`` whether it was an edge or corner, ``normal`` (R, 3) the
    contact's normal, ``y`` (R, n_out) the restarted throw's outputs there and ``p`` (R, 3) the object's centre;
    ``p_end`` (R, 3) and ``vz_end`` (R,) its centre and vertical speed at the end of the window."""

    column: torch.Tensor
    edge: torch.Tensor
    normal: torch.Tensor
    y: torch.Tensor
    p: torch.Tensor
    p_end: torch.Tensor
    vz_end: torch.Tensor


def near_edges(throw, t_cross: torch.Tensor, vh: torch.Tensor, vz: torch.Tensor, t_min: float, pos: torch.Tensor,
               u3: torch.Tensor, faces, searched, left: torch.Tensor, radius: float, landing: float) -> NearEdge:
    """R flights whose first plane crossing (at ``t_cross`` (R,) of the throw from ``pos`` (R, 3) at speeds ``vh``,
    ``vz``, direction ``u3``) lies just outside a bouncing face's polygon, searched again: the throw restarted
    :data:`BEFORE` the crossing (not before ``t_min``, the skill's first time) and :func:`first_contacts` over
    :data:`WINDOW` from there."""
    t_s = (t_cross - BEFORE).clamp(min=t_min)
    y_s = q._predict(throw, torch.stack([vh, vz, t_s], dim=1))
    start = _along(pos, u3, y_s)
    kind, face, y, normal, y_end = first_contacts(throw, torch.stack([vh, y_s[:, 2]], dim=1), start, u3, faces,
                                                  searched, left, radius, landing)
    column = torch.where(kind == GROUND, 0, face + 1)
    column = torch.where(kind == NONE, -1, column)
    return NearEdge(column=column, edge=kind == EDGE, normal=normal, y=y, p=_along(start, u3, y),
                    p_end=_along(start, u3, y_end), vz_end=y_end[:, 2])


def _along(start: torch.Tensor, u3: torch.Tensor, y: torch.Tensor) -> torch.Tensor:
    """The centre of a throw from ``start`` along ``u3``: its outputs ``y`` (horizontal, vertical displacement)."""
    return start + y[:, 0:1] * u3 + y[:, 1:2] * torch.tensor([0.0, 0.0, 1.0])


def _unit(v: torch.Tensor) -> torch.Tensor:
    return v / v.norm(dim=-1, keepdim=True).clamp(min=1e-9)


def bounces(face) -> bool:
    """Whether a face gives a bounce (its restitution is hidden or not 0): the faces whose edges are searched."""
    return isinstance(face.restitution, str) or float(face.restitution) != 0.0


def first_contacts(throw, x: torch.Tensor, start: torch.Tensor, u3: torch.Tensor, faces, searched, left: torch.Tensor,
                   radius: float, landing: float, t0: float = 0.0, t1: float = WINDOW):
    """The first event of R flights among the ground, the faces' polygons and the searched faces' edges.

    Args:
        throw: the throw skill; x: (R, 2) its inputs (horizontal and vertical speed); start: (R, 3) where each
            flight starts; u3: (R, 3) its horizontal direction.
        faces: per face of the scene, its vertices (R, K, 3) and normals (R, 3); searched: per face, whether its
            edges are events; left: (R,) a face each row does not meet again (-1: none).
        radius: the object's radius; landing: the landing height; t0, t1: the throw's time range.

    Returns ``(kind, face, y, normal, y_end)``: per row :data:`NONE`, :data:`GROUND`, :data:`FACE` or :data:`EDGE`,
    the face met (or whose edge was met), the throw's outputs at the event (R, n_out), the contact normal (R, 3),
    and the throw's outputs at ``t1`` (where a row met nothing, its flight goes on from there).
    """
    up = torch.tensor([0.0, 0.0, 1.0])
    edges = [(f, v[:, k], v[:, (k + 1) % v.shape[1]]) for f, (v, _) in enumerate(faces) if searched[f]
             for k in range(v.shape[1])]
    n_faces = len(faces)
    first_v = torch.stack([v[:, 0] for v, _ in faces], dim=1)                     # (R, F, 3)
    normals = torch.stack([nrm for _, nrm in faces], dim=1)
    ends_a = torch.stack([a for _, a, _ in edges], dim=1)                          # (R, E, 3)
    ends_b = torch.stack([b for _, _, b in edges], dim=1)
    col_face = torch.tensor([f for f in range(n_faces)] + [f for f, _, _ in edges])   # each event's face

    def where(y, i):
        return _along(start[i], u3[i], y)

    def edge_gap(a, b, p):
        return (p - geo.segment_closest(a, b, p)).norm(dim=-1) - radius

    def measure(y, t, i):
        p = where(y, i)
        g_f = geo.plane_offset(first_v[i], normals[i], p[:, None, :]) - radius                  # (R, F)
        g_e = edge_gap(ends_a[i], ends_b[i], p[:, None, :])                                   # (R, E)
        g = torch.cat([g_f, g_e], dim=1)
        g = torch.where(left[i][:, None] == col_face, torch.ones_like(g), g)
        return torch.cat([(p[:, 2] - landing)[:, None], g], dim=1)

    def measure_one(y, t, i, col):
        p = where(y, i)
        k = (col - 1).clamp(min=0)
        fk = k.clamp(max=n_faces - 1)
        ek = (k - n_faces).clamp(min=0)
        g_f = geo.plane_offset(first_v[i, fk], normals[i, fk], p) - radius
        g_e = edge_gap(ends_a[i, ek], ends_b[i, ek], p)
        g = torch.where(k < n_faces, g_f, g_e)
        g = torch.where(left[i] == col_face[k], torch.ones_like(g), g)
        return torch.where(col == 0, p[:, 2] - landing, g)

    n = x.shape[0]
    points = int(math.ceil((t1 - t0) / GRID_STEP)) + 1
    t_ev, crossed, _ = q.first_events(throw, x, measure, t0, t1, grid_points=points, measure_one=measure_one)
    m = t_ev.shape[1]
    at = torch.cat([x.repeat_interleave(m, 0), t_ev.reshape(-1, 1)], dim=1)
    hit_rows = crossed.reshape(-1)                 # the throw's state read only at the events crossed
    y_hit = q._predict(throw, at[hit_rows])
    y = torch.full((n * m, y_hit.shape[1]), float("nan"))
    y[hit_rows] = y_hit
    y = y.reshape(n, m, -1)
    ok = crossed.clone()
    for f, (v, nrm) in enumerate(faces):
        rows_f = ok[:, f + 1].nonzero()[:, 0]
        if len(rows_f):
            p = where(y[rows_f, f + 1], rows_f) - radius * nrm[rows_f]
            ok[rows_f, f + 1] = geo.inside_polygon(v[rows_f], nrm[rows_f], p)
    rows = torch.arange(n)
    first = torch.where(ok, t_ev, torch.full_like(t_ev, math.inf)).argmin(dim=1)
    none = ~ok.any(dim=1)
    y_first = y[rows, first]
    p = where(y_first, rows)
    kind = torch.where(first == 0, GROUND, torch.where(first <= len(faces), FACE, EDGE))
    kind = torch.where(none, NONE, kind)
    k = (first - 1).clamp(min=0)                          # the event's column among the faces' and the edges'
    face = torch.where((kind == FACE) | (kind == EDGE), col_face[k], torch.zeros_like(k))
    n_face = normals[rows, k.clamp(max=n_faces - 1)]
    ek = (k - n_faces).clamp(min=0)
    # the edge's normal half-way through the contact (on the free path), unless the arrival grazes that normal or
    # it faces down (outside every bounce skill's domain): then the normal at the touch
    a_e, b_e = ends_a[rows, ek], ends_b[rows, ek]
    n_touch = _unit(p - geo.segment_closest(a_e, b_e, p))
    p_mid = where(q._predict(throw, torch.cat([x, (t_ev[rows, first] + CONTACT_MID)[:, None]], dim=1)), rows)
    n_mid = _unit(p_mid - geo.segment_closest(a_e, b_e, p_mid))
    v_in = x[:, 0:1] * u3 + y_first[:, 2:3] * up
    towards = -(v_in * n_mid).sum(dim=1)
    fits = ((towards >= general_scene.MIN_NORMAL_SPEED) & (n_mid[:, 2] >= 0)
            & (towards >= math.cos(general_scene.MAX_INCIDENCE) * v_in.norm(dim=1)))
    n_edge = torch.where(fits[:, None], n_mid, n_touch)
    normal = torch.where((kind == EDGE)[:, None], n_edge,
                         torch.where((kind == FACE)[:, None], n_face, torch.zeros_like(n_face)))
    y_end = q._predict(throw, torch.cat([x, torch.full((n, 1), float(t1))], dim=1))
    return kind, face, y_first, normal, y_end
