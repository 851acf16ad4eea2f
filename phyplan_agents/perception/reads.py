"""An RGB-D picture and what can be read from it, object by object: the goal box, a ball, a puck, a horizontal
surface.

:class:`RGBDView` holds one picture from a calibrated camera, with its colour masks and a problem log: each reader
returns ``None`` and logs what it could not measure, rather than raise. :func:`locate_object` reads the green
object alone and raises :class:`PerceptionError`. :mod:`.scene` assembles these reads into a task's state vector.
"""
from __future__ import annotations

from typing import Any, Mapping

import numpy as np

from phyplan_envs import assets

from . import vision as V
from .floor import level_camera

MIN_PIXELS = 6          # fewer pixels than this: not a detection
RED_SLACK = 0.008       # m: a red pixel farther than this outside the fitted goal box is left out by it
RED_OUTSIDE = 0.1       # a goal read that leaves out more than this share of the red pixels is not used


class PerceptionError(RuntimeError):
    """The scene could not be read from the picture (an object not seen, out of view, or a failed fit)."""


class RGBDView:
    """One RGB-D picture with its camera, colour masks and a problem log."""

    def __init__(self, obs: Mapping[str, Any], cam):
        if not isinstance(obs, Mapping) or "rgb" not in obs or "depth" not in obs:
            raise ValueError("perception needs an RGB-D observation: a dict with 'rgb' and 'depth' "
                             "(make the env with obs_mode='rgbd')")
        self.rgb = np.asarray(obs["rgb"])
        # a sensor's invalid pixels (0) take the nearest valid depth; a noisy picture is median-filtered, and its
        # estimated noise (std / depth**2, 0 for an ideal picture) widens the depth tolerances (:meth:`tolerance`)
        self.depth, self.noise = V.denoise_depth(V.fill_invalid(obs["depth"]))
        h, w = self.depth.shape
        if self.rgb.shape[:2] != (h, w):
            raise ValueError(f"rgb {self.rgb.shape} and depth {self.depth.shape} differ in size")
        cam = cam if (cam.height, cam.width) == (h, w) else cam.resized(h, w)
        self.masks = V.colour_masks(self.rgb)
        self.problems: list[str] = []
        self.objects: dict[str, dict[str, Any]] = {}
        # the calibration's tilt and height checked against the floor (unchanged for an ideal camera: floor.py)
        self._points = cam.depth_to_world(self.depth)
        self.cam = level_camera(cam, self._points, ~(self.masks["green"] | self.masks["red"] | self.masks["blue"]))
        if self.cam is not cam:
            self._points = None

    def tolerance(self, base: float, mask: np.ndarray) -> float:
        """A height tolerance (m) for the pixels of ``mask``: ``base`` (an ideal picture's), or three times the raw
        depth noise at their median depth if that is larger (so that a noisy rim pixel still counts)."""
        if self.noise == 0.0 or not mask.any():
            return base
        return max(base, 3.0 * self.noise * float(np.median(self.depth[mask])) ** 2)

    @property
    def points(self) -> np.ndarray:
        """World points of every pixel (H, W, 3)."""
        if self._points is None:
            self._points = self.cam.depth_to_world(self.depth)
        return self._points

    def blob(self, colour: str, what: str, rank: int = 0) -> V.Blob | None:
        """The ``rank``-th largest blob of ``colour`` (``None`` and a problem logged if missing or cut off)."""
        blobs = V.components(self.masks[colour], MIN_PIXELS)
        if len(blobs) <= rank:
            self.problems.append(f"{what}: not detected (no {colour} blob of >= {MIN_PIXELS} pixels in view)")
            return None
        b = blobs[rank]
        if b.at_border:
            self.problems.append(f"{what}: touches the picture's border (partly out of view)")
            return None
        return b

    def fit(self, what: str, fn, *args, **kwargs):
        """``fn(*args, **kwargs)``, or ``None`` with a problem logged if the fit fails."""
        try:
            return fn(*args, **kwargs)
        except (ValueError, np.linalg.LinAlgError) as exc:
            self.problems.append(f"{what}: fit failed ({exc})")
            return None


# ================================================================================================= object readers
def read_goal(view: RGBDView) -> tuple[np.ndarray | None, dict]:
    """The goal box's centre (x, y): a rectangle of the known 0.1 m side fitted to the red blob's outline."""
    b = view.blob("red", "goal")
    if b is None:
        return None, {}
    edges = V.edge_points(view.cam, view.depth, b.mask)
    fit = view.fit("goal", V.fit_rectangle, edges[:, :2], half=assets.GOAL_HALF)
    if fit is None:
        return None, {"pixels": b.pixels}
    centre, half = fit
    if np.any(np.abs(half - assets.GOAL_HALF) > 0.3 * assets.GOAL_HALF):
        view.problems.append(f"goal: the red blob is not a 0.1 m box (measured half sizes {half.round(3).tolist()})")
        return None, {"pixels": b.pixels}
    # the box must hold the red pixels: a box placed by too few or wrong sides (a goal mostly hidden, in a noisy
    # picture) leaves some out; an ideal picture's lie within 2 mm of the fitted box
    red = V.world_points(view.cam, view.depth, b.mask)[:, :2]
    outside = np.max(np.abs(red - centre) - assets.GOAL_HALF, axis=1) > RED_SLACK
    if outside.mean() > RED_OUTSIDE:
        view.problems.append(f"goal: the fitted box leaves {outside.sum()} of the {len(red)} red pixels out")
        return None, {"pixels": b.pixels}
    return centre, {"pixels": b.pixels, "half": half.tolist(), "outline_points": len(edges)}


def read_ball(view: RGBDView, radius: float) -> tuple[np.ndarray | None, dict]:
    """The ball's centre (x, y, z): a sphere of known ``radius`` fitted to the green blob's surface points."""
    b = view.blob("green", "ball")
    if b is None:
        return None, {}
    pts = V.world_points(view.cam, view.depth, b.mask)
    # a ball's visible surface spans less than its radius in depth: a green pixel much nearer or farther than the
    # blob's median (a rim pixel showing the floor behind, in a noisy picture) is not on it
    rng = np.linalg.norm(pts - view.cam.position, axis=1)
    pts = pts[np.abs(rng - np.median(rng)) < 2 * radius]
    c = view.fit("ball", V.fit_sphere, pts, radius, view.cam.position)
    return c, {"pixels": b.pixels}


def read_puck(view: RGBDView, radius: float, half_height: float) -> tuple[np.ndarray | None, dict]:
    """The puck's centre (x, y, z): a circle fitted to the outline of its top face, ``half_height`` below it."""
    b = view.blob("green", "puck")
    if b is None:
        return None, {}
    pts = V.world_points(view.cam, view.depth, b.mask)
    top_z = float(np.percentile(pts[:, 2], 90))
    tol = view.tolerance(0.002, b.mask)
    v, u = np.nonzero(b.mask)
    on_top = np.abs(pts[:, 2] - top_z) < tol
    top = np.zeros_like(b.mask)
    top[v[on_top], u[on_top]] = True
    edges = V.edge_points(view.cam, view.depth, top)
    edges = edges[np.abs(edges[:, 2] - top_z) < tol]
    fit = view.fit("puck", V.fit_circle, edges[:, :2])
    if fit is None:
        return None, {"pixels": b.pixels}
    centre, r = fit
    if abs(r - radius) > 0.4 * radius:     # too few or biased outline points: the top face's centroid instead
        centre = pts[on_top, :2].mean(axis=0)
    return np.array([centre[0], centre[1], top_z - half_height]), {"pixels": b.pixels, "radius": r}


def read_horizontal_plane(view: RGBDView, what: str, z_range: tuple[float, float],
                          exclude: np.ndarray | None = None) -> tuple[float | None, np.ndarray | None]:
    """Height of the largest horizontal surface seen with heights in ``z_range`` (uncoloured pixels), and its
    pixel mask: the mode of the heights, then a plane fit to the pixels within 4 mm of it."""
    z = view.points[..., 2]
    cand = (z > z_range[0]) & (z < z_range[1])
    for m in view.masks.values():
        cand &= ~m
    if exclude is not None:
        cand &= ~exclude
    if cand.sum() < 50:
        view.problems.append(f"{what}: not detected (no surface seen at heights {z_range} m)")
        return None, None
    hist, edges = np.histogram(z[cand], bins=np.arange(z_range[0], z_range[1] + 0.002, 0.002))
    mode = edges[np.argmax(hist)] + 0.001
    near = cand & (np.abs(z - mode) < view.tolerance(0.004, cand & (np.abs(z - mode) < 0.004)))
    blob = V.largest_component(near)
    fit = view.fit(what, V.fit_plane, view.points[blob.mask])
    if fit is None:
        return None, None
    n, c = fit
    if n[2] < 0.99:
        view.problems.append(f"{what}: the fitted surface is not horizontal (normal {n.round(3).tolist()})")
        return None, None
    centre = view.points[blob.mask].mean(axis=0)
    return float((c - n[0] * centre[0] - n[1] * centre[1]) / n[2]), blob.mask


def locate_object(obs: Mapping[str, Any], camera, kind: str, radius: float,
                  half_height: float = 0.0) -> np.ndarray:
    """The centre (x, y, z) of the green object (``kind`` ``"ball"`` or ``"puck"``) in one RGB-D picture, or
    :class:`PerceptionError` (not seen, cut off by the picture's border, failed fit)."""
    view = RGBDView(obs, camera)
    if kind == "ball":
        centre, _ = read_ball(view, radius)
    elif kind == "puck":
        centre, _ = read_puck(view, radius, half_height)
    else:
        raise ValueError(f"kind must be 'ball' or 'puck', got {kind!r}")
    if centre is None:
        raise PerceptionError(f"{kind}: " + "; ".join(view.problems))
    return centre
