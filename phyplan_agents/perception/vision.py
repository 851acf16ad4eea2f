"""Classic vision on one RGB-D picture: colour classes, connected components, back-projection and shape fits.

Everything here works on what a calibrated RGB-D camera gives: the picture, its z-depth and the camera model
(:class:`phyplan_envs.camera.CameraModel`). Nothing reads the simulator.

* :func:`fill_invalid`: depth pixels a sensor reports as invalid (0, negative or not finite) take the depth of the
  nearest valid pixel, so that no point falls at the camera's centre; :func:`depth_noise` estimates a picture's
  depth noise (0 for an ideal one) and :func:`denoise_depth` median-filters a noisy picture, keeping depth edges;
* :func:`colour_masks`: per-pixel classes of the suite's known paint colours (object green, goal red, tool blue)
  from chromaticity ratios, so that shading does not matter;
* :func:`largest_component`: the biggest 8-connected blob of a mask, with its pixel count and whether it touches
  the picture's border (an object partly out of view);
* :func:`edge_points`: sub-pixel silhouette points of a blob in the world: for each pixel of the blob next to a
  pixel outside it that shows a background (not an occluder), the midpoint of the two pixel rays cut at the inside
  pixel's height;
* fits: :func:`fit_plane`, :func:`fit_sphere` (known radius), :func:`fit_circle`, :func:`fit_rectangle`.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy import ndimage

# Chromaticity rules of the paint colours (assets: OBJECT_RGBA green, GOAL_RGBA red, TOOL_RGBA blue). The ratios
# separate them from the greys of the ground, tables and rig, and from the wood pedestal (R/G 1.33).
NOISY_DEPTH = 1e-4     # 1/m: depth noise (std / depth**2) above which a depth picture is median-filtered
MIN_BRIGHT = 60        # the dominant channel must be at least this (0-255): dark pixels carry no colour


def fill_invalid(depth: np.ndarray) -> np.ndarray:
    """``depth`` (float64) with every invalid pixel (not finite, or <= 0: a sensor's "no depth") set to the depth of
    the nearest valid pixel; ``depth`` itself (no copy) if every pixel is valid. ``ValueError`` if none is."""
    d = np.asarray(depth, dtype=np.float64)
    bad = ~(np.isfinite(d) & (d > 0))
    if not bad.any():
        return d
    if bad.all():
        raise ValueError("the depth picture has no valid pixel")
    _, (i, j) = ndimage.distance_transform_edt(bad, return_indices=True)
    return d[i, j]


def depth_noise(depth: np.ndarray) -> float:
    """A robust estimate of the depth noise relative to depth squared (1/m, as a structured-light sensor's std
    ``k z**2``): the median absolute deviation of each pixel from its 3 x 3 median, over ``z**2``, scaled to a
    Gaussian's std (on a noise-free picture ~0: planes and edges leave the median unchanged almost everywhere)."""
    d = np.asarray(depth, dtype=np.float64)
    r = np.abs(d - ndimage.median_filter(d, size=3, mode="nearest")) / (d * d)
    # the MAD of a Gaussian is 0.6745 std; against a 3 x 3 median (itself noisy) the residual's std is ~1.13x
    return float(np.median(r) / 0.6745 / 1.13)


def denoise_depth(depth: np.ndarray, size: int = 5, keep: float = 4.0) -> tuple[np.ndarray, float]:
    """``(depth, 0.0)`` if ``depth`` is not noisy (:func:`depth_noise` at most :data:`NOISY_DEPTH`), else the
    picture median-filtered over ``size`` x ``size`` pixels and the estimated noise ``k``. A pixel whose median
    differs from it by more than ``keep`` times the noise (``k z**2``) keeps its own depth: there the window
    straddles a depth edge (a small object's rim against the floor behind it), and the pixel's own depth, noisy but
    of the right surface, is better."""
    d = np.asarray(depth, dtype=np.float64)
    k = depth_noise(d)
    if k <= NOISY_DEPTH:
        return d, 0.0
    m = ndimage.median_filter(d, size=size, mode="nearest")
    return np.where(np.abs(m - d) <= keep * k * d * d, m, d), k


def colour_masks(rgb: np.ndarray) -> dict[str, np.ndarray]:
    """Boolean masks ``{"green", "red", "blue"}`` of an H x W x 3 uint8 picture."""
    if rgb.ndim != 3 or rgb.shape[2] != 3 or rgb.dtype != np.uint8:
        raise ValueError(f"rgb must be an H x W x 3 uint8 picture, got {rgb.dtype} {rgb.shape}")
    r, g, b = (rgb[..., k].astype(np.float32) for k in range(3))
    return {
        "green": (g >= MIN_BRIGHT) & (g > 1.6 * r) & (g > 1.6 * b),
        "red": (r >= MIN_BRIGHT) & (r > 2.5 * g) & (r > 2.5 * b),
        "blue": (b >= MIN_BRIGHT) & (b > 1.9 * r) & (b > 1.2 * g),
    }


@dataclass
class Blob:
    """One connected component: its mask, pixel count and whether it touches the picture's border."""

    mask: np.ndarray
    pixels: int
    at_border: bool


def components(mask: np.ndarray, min_pixels: int = 1) -> list[Blob]:
    """The 8-connected components of ``mask`` with at least ``min_pixels`` pixels, largest first."""
    labels, n = ndimage.label(mask, structure=np.ones((3, 3), dtype=bool))
    if n == 0:
        return []
    sizes = np.bincount(labels.ravel())[1:]
    border = np.zeros(n + 1, dtype=bool)
    for edge in (labels[0], labels[-1], labels[:, 0], labels[:, -1]):
        border[edge] = True
    out = [Blob(labels == k + 1, int(sizes[k]), bool(border[k + 1])) for k in np.argsort(-sizes)
           if sizes[k] >= min_pixels]
    return out


def largest_component(mask: np.ndarray) -> Blob | None:
    """The largest 8-connected component of ``mask`` (``None`` if the mask is empty)."""
    blobs = components(mask)
    return blobs[0] if blobs else None


def world_points(cam, depth: np.ndarray, mask: np.ndarray) -> np.ndarray:
    """World points (N, 3) of the pixels of ``mask``."""
    v, u = np.nonzero(mask)
    return cam.back_project(u + 0.5, v + 0.5, depth[v, u])


def _ray_at_height(cam, u: np.ndarray, v: np.ndarray, z: np.ndarray) -> np.ndarray:
    """Where the rays through pixel coordinates (u, v) cross the horizontal planes at heights ``z``."""
    d = cam.back_project(u, v, np.ones_like(u)) - cam.position      # ray directions (unit z-depth)
    s = (z - cam.position[2]) / d[:, 2]
    return cam.position + s[:, None] * d


def edge_points(cam, depth: np.ndarray, mask: np.ndarray, occluder_rise: float = 0.002) -> np.ndarray:
    """Sub-pixel silhouette points (N, 3) of the blob ``mask`` against the background (module docstring).

    A boundary pixel is skipped when its outside neighbour shows a surface higher than the inside pixel's point
    by more than ``occluder_rise`` (m): a ray that meets something *above* the blob's edge height before crossing
    that height passes in front of the blob, so the blob is hidden there and its outline is unknown. (The ground
    or a table top in front of or behind the blob is lower: a true background.)
    """
    h, w = mask.shape
    out = []
    for di, dj in ((1, 0), (-1, 0), (0, 1), (0, -1)):
        shifted = np.zeros_like(mask)      # shifted[i, j] = mask[i + di, j + dj]; valid: that pixel exists
        valid = np.zeros_like(mask)
        shifted[max(-di, 0):h + min(-di, 0), max(-dj, 0):w + min(-dj, 0)] = \
            mask[max(di, 0):h + min(di, 0), max(dj, 0):w + min(dj, 0)]
        valid[max(-di, 0):h + min(-di, 0), max(-dj, 0):w + min(-dj, 0)] = True
        vi, ui = np.nonzero(mask & ~shifted & valid)
        if len(vi) == 0:
            continue
        vo, uo = vi + di, ui + dj
        p_in = cam.back_project(ui + 0.5, vi + 0.5, depth[vi, ui])
        hit_out = cam.back_project(uo + 0.5, vo + 0.5, depth[vo, uo])
        background = hit_out[:, 2] <= p_in[:, 2] + occluder_rise
        if not np.any(background):
            continue
        p_in = p_in[background]
        p_out = _ray_at_height(cam, uo[background] + 0.5, vo[background] + 0.5, p_in[:, 2])
        out.append(0.5 * (p_in + p_out))
    return np.concatenate(out) if out else np.zeros((0, 3))


# ======================================================================================================== fits
def fit_plane(points: np.ndarray) -> tuple[np.ndarray, float]:
    """Least-squares plane ``n . p = c`` through ``points`` (N >= 3): unit normal (pointing up) and offset."""
    p = np.asarray(points, dtype=np.float64)
    if len(p) < 3:
        raise ValueError(f"a plane fit needs at least 3 points, got {len(p)}")
    centre = p.mean(axis=0)
    _, _, vt = np.linalg.svd(p - centre, full_matrices=False)
    n = vt[-1]
    if n[2] < 0:
        n = -n
    return n, float(n @ centre)


def fit_sphere(points: np.ndarray, radius: float, toward: np.ndarray) -> np.ndarray:
    """Centre of a sphere of known ``radius`` whose visible surface is ``points`` (seen from ``toward``)."""
    p = np.asarray(points, dtype=np.float64)
    if len(p) < 4:
        raise ValueError(f"a sphere fit needs at least 4 points, got {len(p)}")
    m = p.mean(axis=0)
    ray = m - np.asarray(toward, dtype=np.float64)
    c = m + radius * 0.5 * ray / np.linalg.norm(ray)     # the visible cap's centroid lies ~r/2 in front
    for _ in range(20):                                   # Gauss-Newton on |p - c| - r
        d = p - c
        dist = np.linalg.norm(d, axis=1)
        res = dist - radius
        jac = -d / dist[:, None]
        step, *_ = np.linalg.lstsq(jac, -res, rcond=None)
        c = c + step
        if np.linalg.norm(step) < 1e-7:
            break
    return c


def fit_circle(xy: np.ndarray) -> tuple[np.ndarray, float]:
    """Least-squares circle through 2-D points (N >= 3): centre and radius (algebraic fit, then Gauss-Newton)."""
    p = np.asarray(xy, dtype=np.float64)
    if len(p) < 3:
        raise ValueError(f"a circle fit needs at least 3 points, got {len(p)}")
    a = np.column_stack([2 * p, np.ones(len(p))])
    sol, *_ = np.linalg.lstsq(a, (p ** 2).sum(axis=1), rcond=None)
    c = sol[:2]
    r = float(np.sqrt(sol[2] + c @ c))
    for _ in range(20):
        d = p - c
        dist = np.linalg.norm(d, axis=1)
        jac = np.column_stack([-d / dist[:, None], -np.ones(len(p))])
        step, *_ = np.linalg.lstsq(jac, -(dist - r), rcond=None)
        c, r = c + step[:2], r + float(step[2])
        if np.linalg.norm(step) < 1e-8:
            break
    return c, r


def fit_rectangle(xy: np.ndarray, yaw: float = 0.0, half=None, corner_margin: float = 0.2,
                  iterations: int = 8) -> tuple[np.ndarray, np.ndarray]:
    """Centre (2,) and half sizes (2,) of a rectangle at ``yaw`` whose outline the 2-D points ``xy`` sample.

    Each point is given to the side it is closest to (relative to the current estimate); points within
    ``corner_margin`` (a fraction of the half size) of a corner are left out, as their side is ambiguous. Each side's
    position is the median of its points. Free size (``half=None``): the centre is the midpoint of opposite sides,
    and every side must be sampled. Known ``half`` (2,): each sampled side gives the centre (side -+ half), so a
    rectangle partly hidden (one side of an axis unseen) is still placed; the returned half sizes are then the
    measured ones where both sides were seen, else ``half``. If neither side of an axis is seen, the midpoint of
    the points' extent along it is the centre, provided that extent matches the size within 20 %.
    """
    p = np.asarray(xy, dtype=np.float64)
    if len(p) < 6:
        raise ValueError(f"a rectangle fit needs at least 6 outline points, got {len(p)}")
    known = None if half is None else np.broadcast_to(np.asarray(half, dtype=np.float64), (2,)).copy()
    c_, s_ = np.cos(yaw), np.sin(yaw)
    rot = np.array([[c_, -s_], [s_, c_]])                 # local -> world
    q = p @ rot                                           # world -> local
    lo, hi = q.min(axis=0), q.max(axis=0)
    centre = (lo + hi) / 2
    size = (hi - lo) / 2 if known is None else known.copy()
    size = np.maximum(size, 1e-6)
    for _ in range(iterations):
        rel = (q - centre) / size
        on_x = np.abs(rel[:, 0]) >= np.abs(rel[:, 1])     # on a side of constant local x
        new_centre, new_size = centre.copy(), size.copy()
        for axis, sel in ((0, on_x), (1, ~on_x)):
            keep = sel & (np.abs(rel[:, 1 - axis]) <= 1 - corner_margin)
            neg, pos = keep & (rel[:, axis] < 0), keep & (rel[:, axis] > 0)
            lo_side = np.median(q[neg, axis]) if neg.sum() >= 2 else None
            hi_side = np.median(q[pos, axis]) if pos.sum() >= 2 else None
            if lo_side is not None and hi_side is not None:
                new_size[axis] = (hi_side - lo_side) / 2
                if known is None:
                    new_centre[axis] = (lo_side + hi_side) / 2
                    continue
            elif known is None:
                raise ValueError("the outline points do not sample two opposite sides of the rectangle")
            est = [v for v in (None if lo_side is None else lo_side + known[axis],
                               None if hi_side is None else hi_side - known[axis]) if v is not None]
            if not est:        # no side of this axis seen: the outline's extent along it, if it spans the size
                lo_q, hi_q = q[:, axis].min(), q[:, axis].max()
                if abs((hi_q - lo_q) - 2 * known[axis]) > 0.2 * known[axis]:
                    raise ValueError(f"the outline points sample no side of the rectangle along its local "
                                     f"{'xy'[axis]} axis")
                est = [(lo_q + hi_q) / 2]
            new_centre[axis] = float(np.mean(est))
        done = np.allclose(new_centre, centre, atol=1e-7)
        centre = new_centre
        size = new_size if known is None else known
        if done:
            break
    return rot @ centre, (new_size if known is None else np.where(new_size > 0, new_size, known))
