"""Hand orientations for a grasp: the grasp frame from an approach and a closing axis, and the candidates to try.

Pure geometry (numpy only). A grasp frame is a rotation matrix whose columns are x, y = the fingers' closing axis
and z = the approach (out of the fingers), matching the ``grasp`` site of :mod:`phyplan_envs.panda.model`.
"""
from __future__ import annotations

import math

import numpy as np


def yaw_matrix(yaw: float) -> np.ndarray:
    """The rotation by ``yaw`` (rad) about the world z axis."""
    c, s = math.cos(yaw), math.sin(yaw)
    return np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])


def cross3(a, b) -> np.ndarray:
    """``numpy.cross`` of two 3-vectors, written out (the same products and differences, so the same bits, at a
    fraction of its cost, docs/robot.md: robot mode builds a hand rotation per waypoint and a body-point velocity
    per wait step)."""
    return np.array([a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]])


def grasp_rotation(approach, closing) -> np.ndarray:
    """The grasp frame as a rotation matrix (columns x, y, z): z = ``approach``, y = ``closing`` made orthogonal."""
    z = np.asarray(approach, dtype=np.float64)
    z = z / np.linalg.norm(z)
    y = np.asarray(closing, dtype=np.float64)
    y = y - (y @ z) * z
    ny = np.linalg.norm(y)
    if ny < 1e-9:
        raise ValueError(f"closing axis {closing!r} is parallel to the approach {approach!r}")
    y = y / ny
    return np.column_stack([cross3(y, z), y, z])


def _unit(v) -> np.ndarray:
    v = np.asarray(v, dtype=np.float64)
    return v / np.linalg.norm(v)


def grasp_candidates(target, shoulder, rod_top=None) -> list[np.ndarray]:
    """Hand orientations (rotation matrices in the world frame) to try for holding ``target``, best guess first.

    With ``rod_top`` (the pivot of a pendulum whose bob is at ``target``) the fingers close across the swing plane
    and the hand approaches perpendicular to the rod from above (a top-down grasp when the rod is horizontal), or
    it comes from the side along the hinge axis, closing in the swing plane; candidates whose approach points
    away from the arm's ``shoulder`` (towards the target) come first. Without a rod: a top-down grasp with the
    fingers closing across the line from the shoulder to the target. Both finger orderings are listed (the hand is
    symmetric, the joint limits are not).
    """
    target = np.asarray(target, dtype=np.float64)
    reach = target - np.asarray(shoulder, dtype=np.float64)
    reach_h = np.array([reach[0], reach[1], 0.0])
    if np.linalg.norm(reach_h) < 1e-6:
        reach_h = np.array([1.0, 0.0, 0.0])
    reach_dir = _unit(reach)
    across = _unit(np.cross([0.0, 0.0, 1.0], reach_h))
    down = np.array([0.0, 0.0, -1.0])
    pairs: list[tuple[np.ndarray, np.ndarray]] = []
    rod = None if rod_top is None else np.asarray(rod_top, dtype=np.float64) - target
    if rod is not None and np.linalg.norm(rod) > 1e-6:
        r = _unit(rod)
        hinge = np.cross(r, [0.0, 0.0, 1.0])
        if np.linalg.norm(hinge) < 1e-6:        # vertical rod: any horizontal hinge; take the one across the reach
            hinge = across
        hinge = _unit(hinge)
        over = _unit(np.cross(r, hinge))       # perpendicular to the rod, in the swing plane
        if over[2] > 0:
            over = -over
        if hinge @ reach_dir < 0:
            hinge = -hinge
        pairs = [(over, hinge), (hinge, over)]
        pairs.sort(key=lambda p: -float(p[0] @ reach_dir))
    else:
        pairs = [(down, across)]
    out = []
    for approach, closing in pairs:
        out.append(grasp_rotation(approach, closing))
        out.append(grasp_rotation(approach, -closing))
    return out
