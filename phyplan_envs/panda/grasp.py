"""Grasp frames, shared by the posed arm and robot mode: the grasp frame from an approach and a closing axis.

Pure geometry (numpy only). A grasp frame is a rotation matrix whose columns are x, y = the fingers' closing axis
and z = the approach (out of the fingers), matching the ``grasp`` site of :mod:`phyplan_envs.panda.model`.
Public names: :func:`grasp_rotation`, :func:`yaw_matrix` (the Panda's base turned about z) and :func:`cross3`
(``numpy.cross`` of two 3-vectors, written out). The hand orientations the posed arm tries for a target are
:func:`phyplan_envs.panda.posed.candidates.grasp_candidates`.
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
