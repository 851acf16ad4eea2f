"""The hand orientations the posed arm tries for holding a target: :func:`grasp_candidates`.

Pure geometry (numpy only); the grasp frames are :func:`phyplan_envs.panda.grasp.grasp_rotation`'s.
"""
from __future__ import annotations

import numpy as np

from ..grasp import grasp_rotation


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
