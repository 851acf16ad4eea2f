"""Batched geometry of a scene description's parts for the chain composer: where a straight path leaves a support's
top, whether a point lies on a top, and where a point is relative to a face (float32 torch, one row per action).

The parts are :mod:`phyplan_envs.description`'s: a :class:`~phyplan_envs.description.Support` is a disc or a turned
rectangle, a :class:`~phyplan_envs.description.Face` a convex polygon with its outward normal, an
:class:`~phyplan_envs.description.Obstacle` an upright block over a turned rectangle.
"""
from __future__ import annotations

import numpy as np
import torch

BIG = 1e6          # m: "never" for a path that does not leave a region


def rows(x, n: int, width: int | None = None) -> torch.Tensor:
    """A description array (constant or per action) as a float32 tensor with ``n`` rows."""
    t = torch.as_tensor(np.asarray(x, dtype=np.float64), dtype=torch.float32)
    if width is None:
        return t.expand(n) if t.ndim == 0 else t
    return t.expand(n, width) if t.ndim == 1 else t


def pick(x, idx, const_ndim: int):
    """Rows ``idx`` of a per-action description array (one more axis than a constant's ``const_ndim``), or the
    constant itself."""
    a = np.asarray(x)
    return a if idx is None or a.ndim == const_ndim else a[idx.numpy()]


def to_local(support, xy: torch.Tensor, u: torch.Tensor, idx=None) -> tuple[torch.Tensor, torch.Tensor]:
    """Point ``xy`` (n, 2) and direction ``u`` (n, 2) in a support's own frame (its centre, turned by its yaw);
    ``idx``: the description rows of the n points (default all)."""
    n = xy.shape[0]
    c = rows(pick(support.centre, idx, 1), n, 2)
    yaw = rows(pick(support.yaw, idx, 0), n)
    cos, sin = torch.cos(yaw), torch.sin(yaw)
    d = xy - c

    def turn(v):
        return torch.stack([cos * v[:, 0] + sin * v[:, 1], -sin * v[:, 0] + cos * v[:, 1]], dim=1)

    return turn(d), turn(u)


def contains(support, xy: torch.Tensor, idx=None, margin: float = 0.0) -> torch.Tensor:
    """Whether points ``xy`` (n, 2) lie on the support's top (within ``margin`` beyond its edge); ``idx`` as in
    :func:`to_local`."""
    p, _ = to_local(support, xy, torch.zeros_like(xy), idx)
    if support.shape == "disc":
        return p.norm(dim=1) <= support.radius + margin
    half = torch.as_tensor(np.asarray(support.half, dtype=np.float64), dtype=torch.float32)
    return (p.abs() <= half + margin).all(dim=1)


def exit_distance(support, xy: torch.Tensor, u: torch.Tensor, idx=None) -> torch.Tensor:
    """How far (m) a point at ``xy`` (n, 2) on the support's top moves along the unit direction ``u`` (n, 2) before
    its centre passes the top's edge (0 for a point already outside); ``idx`` as in :func:`to_local`."""
    p, v = to_local(support, xy, u, idx)
    if support.shape == "disc":
        r = support.radius
        b = (p * v).sum(dim=1)
        c = (p * p).sum(dim=1) - r * r
        return (-b + torch.sqrt((b * b - c).clamp(min=0.0))).clamp(min=0.0)
    half = torch.as_tensor(np.asarray(support.half, dtype=np.float64), dtype=torch.float32)
    safe = torch.where(v.abs() > 1e-9, v, torch.full_like(v, 1e-9))
    t = torch.where(v > 0, (half - p) / safe, (-half - p) / safe)
    t = torch.where(v.abs() > 1e-9, t, torch.full_like(t, BIG))
    return t.min(dim=1).values.clamp(min=0.0)


def face_arrays(face, n: int) -> tuple[torch.Tensor, torch.Tensor]:
    """A face's vertices (n, k, 3) and outward unit normal (n, 3) as tensors."""
    v = torch.as_tensor(np.asarray(face.vertices, dtype=np.float64), dtype=torch.float32)
    nrm = torch.as_tensor(np.asarray(face.normal, dtype=np.float64), dtype=torch.float32)
    if v.ndim == 2:
        v = v.expand(n, *v.shape)
    if nrm.ndim == 1:
        nrm = nrm.expand(n, 3)
    return v, nrm


def plane_offset(q: torch.Tensor, normal: torch.Tensor, p: torch.Tensor) -> torch.Tensor:
    """Signed distance (m) of points ``p`` from the planes through points ``q`` with unit normals ``normal``, positive
    on the normal's side; the three broadcast against each other (last axis: xyz)."""
    return ((p - q) * normal).sum(dim=-1)


def plane_distance(vertices: torch.Tensor, normal: torch.Tensor, p: torch.Tensor) -> torch.Tensor:
    """Signed distance (m) of points ``p`` (n, ..., 3) from each face's plane, positive on its outward side;
    ``vertices`` (n, k, 3), ``normal`` (n, 3). Extra middle axes of ``p`` broadcast (e.g. a time grid)."""
    extra = p.ndim - 2
    q = vertices[:, 0].reshape(vertices.shape[0], *([1] * extra), 3)
    nrm = normal.reshape(normal.shape[0], *([1] * extra), 3)
    return plane_offset(q, nrm, p)


def inside_polygon(vertices: torch.Tensor, normal: torch.Tensor, p: torch.Tensor,
                   margin: float | torch.Tensor = 0.0) -> torch.Tensor:
    """Whether the projections of points ``p`` (n, 3) on each face's plane lie inside its convex polygon (grown by
    ``margin`` m: a number, or per point (n, 1)), either winding."""
    a = vertices
    b = torch.roll(vertices, shifts=-1, dims=1)
    edge = b - a                                                  # (n, k, 3)
    rel = p[:, None, :] - a
    side = (torch.linalg.cross(edge, rel, dim=-1) * normal[:, None, :]).sum(dim=-1)    # (n, k)
    length = edge.norm(dim=-1).clamp(min=1e-9)
    side = side / length                                          # signed distance from each edge's line
    return (side >= -margin).all(dim=1) | (side <= margin).all(dim=1)


def segment_closest(a: torch.Tensor, b: torch.Tensor, p: torch.Tensor) -> torch.Tensor:
    """The points of segments ``a``-``b`` (..., 3) closest to points ``p`` (..., 3) (broadcast)."""
    d = b - a
    s = (((p - a) * d).sum(dim=-1) / (d * d).sum(dim=-1).clamp(min=1e-12)).clamp(0.0, 1.0)
    return a + s[..., None] * d


def block_arrays(blocks, n: int) -> tuple[torch.Tensor, ...]:
    """Upright blocks (:class:`~phyplan_envs.description.Obstacle` s) as tensors for ``n`` rows: centres (n, O, 2),
    the cosine and sine of their yaws (n, O), half extents (O, 2), bottoms and tops (O,)."""
    centre = torch.stack([rows(b.centre, n, 2) for b in blocks], dim=1)
    yaw = torch.stack([rows(b.yaw, n) for b in blocks], dim=1)
    half = torch.as_tensor(np.array([b.half for b in blocks], dtype=np.float64), dtype=torch.float32)
    bottom = torch.tensor([float(b.bottom) for b in blocks])
    top = torch.tensor([float(b.top) for b in blocks])
    return centre, torch.cos(yaw), torch.sin(yaw), half, bottom, top


def block_distance(arrays, p: torch.Tensor) -> torch.Tensor:
    """The distance (m) from points ``p`` (R, 3) to each of R rows' blocks (``block_arrays`` picked to those rows),
    as the larger of the distance in the plane from the footprint and the height above the top or below the bottom
    (R, O): <= r where a ball of radius r touches a block's side or its top."""
    centre, cos, sin, half, bottom, top = arrays
    d = p[:, None, :2] - centre
    local = torch.stack([cos * d[..., 0] + sin * d[..., 1], -sin * d[..., 0] + cos * d[..., 1]], dim=-1)
    gap = (local.abs() - half).clamp(min=0.0).norm(dim=-1)
    z = p[:, None, 2]
    return torch.maximum(gap, torch.maximum(z - top, bottom - z))


def ray_may_reach(arrays, p: torch.Tensor, u: torch.Tensor, margin: float) -> torch.Tensor:
    """Whether the straight path in the plane from ``p`` (R, 2+) along the unit direction ``u`` (R, 2) comes within
    ``margin`` of each block's footprint (R, O), bounded by the circle round its corners: False only where the path
    surely stays clear of it."""
    centre, _, _, half, _, _ = arrays
    d = centre - p[:, None, :2]                                         # (R, O, 2)
    s = (d * u[:, None, :]).sum(dim=-1).clamp(min=0.0)
    closest = (d - s[..., None] * u[:, None, :]).norm(dim=-1)
    return closest <= half.norm(dim=-1) + margin
