"""Robot-mode plans: the hand paths of the pick-carry-release steps a task's ``robot_plan(action)`` returns.

Each builder takes the task's geometric facts and returns :class:`~phyplan_envs.panda.robot.paths.Carry` steps for
:meth:`~phyplan_envs.panda.robot.RobotArm.execute`. Paths are world poses of the grasp site (rotation columns:
x, closing axis y, approach z), spaced at most :data:`~phyplan_envs.panda.robot.paths.WAYPOINT_STEP` apart.
"""
from __future__ import annotations

import math

import numpy as np

from ..grasp import grasp_rotation
from .paths import WAYPOINT_STEP, Carry

Z = np.array([0.0, 0.0, 1.0])
# Bounce: the hand holds the ball from the robot's side; below TILT_TOP it tilts its approach downwards (up to
# TILT_MAX at 0.5 m), which the arm on its stand reaches at every drop height (a horizontal grasp misses the low ones)
TILT_MAX = math.radians(60.0)
TILT_TOP = 1.1              # m
TILT_LOW = 0.5              # m
PENDULUM_TILTS = (0.0, 0.35, -0.35, 0.7)   # rad: approach turned from the rod's normal, tried in this order
LIFT = 0.05                 # m: the ball is lifted this far off its table before it is carried
BALL_HOLD_TOL = 2e-5        # m: the ball's release accuracy (its landing is not chaotic: robot_check --sensitivity)
PLANK_EDGE_IN = 0.02        # m: the fingers hold the plank this far inside its side edge
PLANK_HOLD_TOL = 1e-5       # m: the plank's release accuracy (3.4e-5 rad of yaw at the grasp, within the 1e-5 to
                            # 6e-5 rad its latch lets it settle by anyway)
# The other finger order: reversing the closing axis flips the grasp frame's x and y columns, exactly (grasp_rotation
# is odd in the closing axis), so the second path of each pair needs no rotation of its own.
FLIP = np.array([-1.0, -1.0, 1.0])


def _segment(a, b) -> list[np.ndarray]:
    """Points from ``a`` (excluded) to ``b`` (included), at most WAYPOINT_STEP apart."""
    a, b = np.asarray(a, dtype=np.float64), np.asarray(b, dtype=np.float64)
    n = max(1, int(math.ceil(np.linalg.norm(b - a) / WAYPOINT_STEP)))
    return [a + (b - a) * k / n for k in range(1, n + 1)]


def pendulum_carry(bob_at, phi: float, theta: float, length: float, half_width: float,
                   body: str = "pendulum_arm") -> Carry:
    """Grasp the hanging bob, carry it up its arc to ``theta`` in the swing plane ``phi``, release.

    ``bob_at(theta)`` is the bob centre's world position at hinge angle ``theta`` (the rig already placed at
    ``phi``). The hand keeps one orientation along the arc: approach ``cos(theta) u - sin(theta) z`` (u the
    horizontal swing direction), i.e. perpendicular to the rod at the release, so the released bob swings out
    between the fingertips; the fingers close along the hinge axis on the bob's side faces, and the bob turns
    between the pads as it is lifted. Both finger orders are offered, and approaches turned by
    :data:`PENDULUM_TILTS` in the swing plane (the joint limits are not symmetric). Until
    the release the bob touches only the fingers (it hangs 0.5 mm behind the object).
    """
    u = np.array([math.cos(phi), math.sin(phi), 0.0])
    hinge = np.cross(Z, u)
    k = max(1, int(math.ceil(abs(theta) * length / WAYPOINT_STEP)))
    points = [np.asarray(bob_at(t), dtype=np.float64) for t in np.linspace(0.0, theta, k + 1)]
    paths = []
    for tilt in PENDULUM_TILTS:      # the approach may turn in the swing plane: the bob still leaves between the pads
        approach = math.cos(theta - tilt) * u - math.sin(theta - tilt) * Z
        rot = grasp_rotation(approach, hinge)     # one hand orientation all along the arc
        for r in (rot, rot * FLIP):               # both finger orders
            paths.append([(p, r) for p in points])
    return Carry(body, half_width, paths[0], alternatives=paths[1:], fingers_only=True)


def drop_carry(start, drop, base_xy, half_width: float, body: str = "ball", fixed_start: bool = True) -> Carry:
    """Pick the resting ball at ``start``, lift it, carry it above ``drop`` and lower it there; release.

    ``fixed_start``: ``start`` is where the ball rests at reset, the same for every action (see :class:`Carry`).

    The hand approaches from the robot's side (horizontally along the line from the base ``base_xy``, tilting down
    below :data:`TILT_TOP`), fingers closing horizontally, so the released ball falls freely between them.
    """
    start = np.asarray(start, dtype=np.float64)
    drop = np.asarray(drop, dtype=np.float64)
    lift = start + LIFT * Z
    over = np.array([drop[0], drop[1], max(lift[2], drop[2])])
    points = [start] + _segment(start, lift) + _segment(lift, over) + _segment(over, drop)
    base_xy = np.asarray(base_xy, dtype=np.float64)

    def rotation(p, sign):
        h = p[:2] - base_xy
        h = h / np.linalg.norm(h)
        tilt = TILT_MAX * min(1.0, max(0.0, (TILT_TOP - p[2]) / (TILT_TOP - TILT_LOW)))
        approach = math.cos(tilt) * np.array([h[0], h[1], 0.0]) - math.sin(tilt) * Z
        return grasp_rotation(approach, sign * np.array([-h[1], h[0], 0.0]))

    first = [(p, rotation(p, 1.0)) for p in points]
    return Carry(body, half_width, first, alternatives=[[(p, r * FLIP) for p, r in first]], fixed_start=fixed_start,
                 hold_tol=BALL_HOLD_TOL)


def plank_carry(yaw_from: float, yaw_to: float, grasp_r: float, width: float, thick: float, top: float,
                base_xy, body: str = "bridge", latch: str = "bridge_yaw", fixed_start: bool = True) -> Carry:
    """Turn a plank about the vertical axis through the world origin from ``yaw_from`` to ``yaw_to``.

    The fingers close vertically on the plank's top and bottom faces ``grasp_r`` from the axis, just inside the
    side edge nearer the arm's base ``base_xy``, the hand approaching horizontally across the plank and turning
    with it; the plank's pivot (``latch``) is free while the arm holds it and locked where the arm leaves it.
    ``fixed_start``: ``yaw_from`` is the plank's rest yaw at reset, the same for every action (see :class:`Carry`).
    """
    zc = top - thick / 2
    base_xy = np.asarray(base_xy, dtype=np.float64)
    mid = grasp_r * np.array([math.cos(yaw_from), math.sin(yaw_from)])
    n0 = np.array([-math.sin(yaw_from), math.cos(yaw_from)])
    side = 1.0 if n0 @ (base_xy - mid) > 0 else -1.0
    off = width / 2 - PLANK_EDGE_IN
    k = max(1, int(math.ceil(abs(yaw_to - yaw_from) * grasp_r / WAYPOINT_STEP)))
    paths = []
    for c in (1.0, -1.0):
        path = []
        for y in np.linspace(yaw_from, yaw_to, k + 1):
            normal = side * np.array([-math.sin(y), math.cos(y), 0.0])
            p = np.array([grasp_r * math.cos(y), grasp_r * math.sin(y), zc]) + off * normal
            path.append((p, grasp_rotation(-normal, c * Z)))
        paths.append(path)
    return Carry(body, thick / 2, paths[0], latch=latch, alternatives=paths[1:], fixed_start=fixed_start,
                 hold_tol=PLANK_HOLD_TOL)
