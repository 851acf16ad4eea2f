"""Robot mode's servo motion: the arm's position servos stepped along joint waypoints (:class:`ArmMotion`, mixed
into :class:`.arm.RobotArm`, whose ``bind`` sets the ids and whose ``execute`` sets ``clock`` and ``on_frame``).

:meth:`ArmMotion.move` tracks joint waypoints with minimum-jerk timing in path length (at :data:`HAND_SPEED` along the
hand's path and :data:`JOINT_SPEED` for the joint that moves most, at least :data:`MIN_MOVE_TIME`), each set-point led
by the servo's lag (damping / kp), then waits until the arm has caught up (``TRACK_TOL`` of :mod:`.sensing`, or
:data:`TRACK_TIMEOUT`); :meth:`ArmMotion._run` steps the physics :data:`CTRL_STEPS` steps per set-point;
:meth:`ArmMotion._clear_way` is the way to a point above a stand-off that keeps the hand :data:`VIA_CLEARANCE` from
the grasp point.
"""
from __future__ import annotations

import math
from typing import Callable, Sequence

import numpy as np

from ..ik import REACH_ORI, REACH_POS
from .paths import VIA_HEIGHT, VIA_ORI_TOL, VIA_POS_TOL
from .sensing import TRACK_TOL

VIA_CLEARANCE = 0.1         # m: the moves to a step's via point keep the hand this far from the grasp point
CTRL_STEPS = 2              # physics steps between actuator set-point updates (every 24 ms at the set-up's step)
HAND_SPEED = 0.5            # m/s: average hand speed along a path (minimum-jerk timing) ...
JOINT_SPEED = 1.0           # rad/s: ... and of the joint that moves most (the set-point's min-jerk peak 1.9 rad/s;
                            # the joints follow at up to force limit / damping, 0.87 rad/s on joints 1-4, 1.2 on 5-7)
# TRACK_TOL (.sensing): a move ends when every arm joint is this close to its set-point ...
TRACK_TIMEOUT = 3.0         # s: ... or after this long (a long move's joints lag their set-points by up to
                            # ~1.7 rad at the force limits, caught up at under 1 rad/s)
MIN_MOVE_TIME = 0.15        # s


class ArmMotion:
    """How :class:`.arm.RobotArm` moves: its servos' set-points stepped along joint waypoints."""

    def _run(self, seconds: float, setpoints: Callable[[np.ndarray], np.ndarray] | None, until=None) -> float:
        """Step the physics for up to ``seconds`` with the arm servo set-points ``setpoints(ts)`` (one row per
        control step at the times ``ts`` from the start; None: hold); stops early when ``until()`` is true.
        Returns the time stepped."""
        m, d = self.model, self.data
        h = CTRL_STEPS * m.opt.timestep
        n = max(1, int(math.ceil(seconds / h)))
        ts = [0.0] * n
        for i in range(1, n):            # the times as a running sum (as the clock advances)
            ts[i] = ts[i - 1] + h
        qs = None if setpoints is None else setpoints(np.array(ts))
        ctrl, act, step, on_frame = d.ctrl, self._arm_act, self.mj_step, self.on_frame
        t = 0.0
        for i in range(n):
            if qs is not None:
                ctrl[act] = qs[i]
            step(m, d, nstep=CTRL_STEPS)
            t += h
            self.clock += h
            if on_frame is not None:
                on_frame(self.clock)
            if until is not None and until():
                break
        if qs is not None:
            self.q_cmd = qs[i].copy()
        return t

    def move(self, qs: Sequence[np.ndarray], length: float, min_time: float = MIN_MOVE_TIME,
             settle: bool | float = True) -> None:
        """Track the joint waypoints ``qs`` (from the current set-point) with minimum-jerk timing in path length."""
        pts = [self.q_cmd.copy()] + [np.asarray(q) for q in qs]
        joint = sum(float(np.max(np.abs(pts[i + 1] - pts[i]))) for i in range(len(pts) - 1))
        T = max(min_time, length / HAND_SPEED, joint / JOINT_SPEED)
        k = len(pts) - 1
        P = np.array(pts)

        def q_at(t):                    # the joint path at the times t (an array), minimum-jerk in path parameter
            s = np.minimum(1.0, np.maximum(0.0, t / T))
            s = s * s * s * (10.0 - 15.0 * s + 6.0 * s * s) * k
            i = np.minimum(s.astype(np.int64), k - 1)
            f = (s - i)[:, None]
            return (1 - f) * P[i] + f * P[i + 1]

        h = CTRL_STEPS * self.model.opt.timestep

        def setpoints(ts):
            # the servos lag a set-point by damping / kp (first order): lead it by that much along the path
            q = q_at(ts)
            return q + self._lag * (q_at(ts + h) - q) / h
        self._run(T, setpoints)
        self.q_cmd = pts[-1].copy()
        self.data.ctrl[self._arm_act] = self.q_cmd
        if settle:   # wait until the arm has caught up with the set-point (to TRACK_TOL, or to ``settle`` rad)
            tol = TRACK_TOL if settle is True else float(settle)
            self._run(TRACK_TIMEOUT, None, until=lambda: self._tracked(tol))

    def _clear_way(self, q_via, grasp_pos) -> list:
        """Joint waypoints from the arm's set-point to ``q_via`` (above the stand-off) that keep the hand at least
        VIA_CLEARANCE from the grasp point: straight in joint space if that does (a joint-space move between two
        poses above the work can dip by ~10 cm on the way), else up by VIA_HEIGHT first, across, and down."""
        direct = [self.q_cmd, q_via]
        if self.paths.closest_approach(direct, grasp_pos) >= VIA_CLEARANCE:
            return [q_via]
        lift = np.array([0.0, 0.0, VIA_HEIGHT])
        p0, r0 = self.ik.forward(self.q_cmd)
        p1, r1 = self.ik.forward(q_via)
        q_up, pe0, oe0 = self.ik.solve(self.q_cmd, p0 + lift, r0, pos_tol=VIA_POS_TOL, ori_tol=VIA_ORI_TOL)
        q_over, pe1, oe1 = self.ik.solve(q_via, p1 + lift, r1, pos_tol=VIA_POS_TOL, ori_tol=VIA_ORI_TOL)
        if max(pe0, pe1) > REACH_POS or max(oe0, oe1) > REACH_ORI:
            return [q_via]                 # no room above: the direct way (the physics shows what it touches)
        return [q_up, q_over, q_via]
