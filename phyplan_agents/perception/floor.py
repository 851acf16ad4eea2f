"""The camera's tilt and height checked against the floor: a self-calibration for a camera that is not quite where
its calibration says.

The world's floor is the plane ``z = 0``. Back-projected through the calibration, the floor pixels of an RGB-D
picture must lie on it; if the camera is turned or raised a little (the env's ``camera_noise`` pose error, or a
knocked real camera), they lie on a slightly tilted, shifted plane, and every point read from the picture is off by
the same rigid motion (about 4 cm at 2.5 m for 1 degree). :func:`level_camera` fits that plane (a robust plane fit
to the uncoloured pixels near ``z = 0``) and returns the calibration turned about the camera's centre and moved
vertically so that the plane becomes the floor: the two tilt angles and the height are measured. The turn about the
vertical and the horizontal shift leave the floor where it is, so no floor can measure them; they stay as they
were.

An ideal picture's floor lies on ``z = 0`` to float precision, and the calibration is then returned unchanged
(the same object): corrections below :data:`MIN_TILT` and :data:`MIN_SHIFT` are not applied.
"""
from __future__ import annotations

import numpy as np

from phyplan_envs.camera import CameraModel

FLOOR_BAND = 0.12       # m: candidate floor pixels lie within this of z = 0 (a 1-2 degree tilt at 2-4 m)
MIN_PIXELS = 500        # fewer candidate floor pixels: no correction
MIN_TILT = np.radians(0.01)   # rad: smaller measured tilts are not corrected
MIN_SHIFT = 2e-4        # m: nor smaller height offsets
INLIER = 0.006          # m: the robust fit's inlier band around the plane (after the first fit)


def _plane(points: np.ndarray) -> tuple[np.ndarray, float]:
    centre = points.mean(axis=0)
    _, _, vt = np.linalg.svd(points - centre, full_matrices=False)
    n = vt[-1] if vt[-1][2] > 0 else -vt[-1]
    return n, float(n @ centre)


def floor_plane(points: np.ndarray, candidates: np.ndarray) -> tuple[np.ndarray, float] | None:
    """The plane ``n . p = c`` (unit normal pointing up) of the floor among ``points[candidates]`` (H x W x 3 and a
    mask), or ``None`` with too few pixels: least squares, then twice again on the points within :data:`INLIER` (or
    three robust standard deviations, if larger: a noisy depth picture) of the last plane."""
    p = points[candidates & (np.abs(points[..., 2]) < FLOOR_BAND)]
    if len(p) < MIN_PIXELS:
        return None
    n, c = _plane(p)
    for _ in range(2):
        r = p @ n - c
        band = max(INLIER, 3.0 * 1.4826 * float(np.median(np.abs(r - np.median(r)))))
        keep = np.abs(r) < band
        if keep.sum() < MIN_PIXELS:
            return None
        n, c = _plane(p[keep])
    return n, c


def level_camera(cam: CameraModel, points: np.ndarray, candidates: np.ndarray) -> CameraModel:
    """``cam`` corrected so that the floor seen in ``points`` (its back-projected picture, H x W x 3; floor
    candidates: the uncoloured pixels, ``candidates``) lies at ``z = 0`` (module docstring); ``cam`` itself if the
    floor is not seen or already level."""
    fit = floor_plane(points, candidates)
    if fit is None:
        return cam
    n, c = fit
    o = cam.position
    up = np.array([0.0, 0.0, 1.0])
    axis = np.cross(n, up)
    sin, cos = float(np.linalg.norm(axis)), float(n @ up)
    # turned about its centre o so that n becomes up, the plane is z = o_z - d (d = n . o - c: the camera's
    # distance above it); moved by -(o_z - d), the plane is the floor: the camera's height is d
    d = float(n @ o - c)
    if np.arctan2(sin, cos) < MIN_TILT and abs(d - o[2]) < MIN_SHIFT:
        return cam
    turn = np.eye(3)
    if sin > 0:
        k = axis / sin
        kx = np.array([[0.0, -k[2], k[1]], [k[2], 0.0, -k[0]], [-k[1], k[0], 0.0]])
        turn = turn + sin * kx + (1.0 - cos) * (kx @ kx)         # takes n to up (Rodrigues)
    return CameraModel(cam.name, cam.width, cam.height, cam.fovy, np.array([o[0], o[1], d]), turn @ cam.rotation)
