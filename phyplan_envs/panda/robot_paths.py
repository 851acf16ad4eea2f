"""Robot mode's path planning: a plan step (:class:`Carry`) turned into joint waypoints by mink IK, checked for reach.

:class:`ArmIK` solves on :func:`phyplan_envs.panda.model.ik_model` (the arm's 7 joints and limits) in the Panda's base
frame, each waypoint warm-started from the previous one with a light posture task towards the home pose turned
towards the target (so neighbouring waypoints stay on one branch of solutions; each iteration by :class:`IKStep`,
mink's ``solve_ik`` bit for bit at about a third of its cost); a waypoint whose residuals exceed
:data:`REACH_POS` / :data:`REACH_ORI` is out of reach (:class:`RobotFailure`). :meth:`ArmIK.plan` plans a whole step
before anything moves: the path, then back out to the stand-off and a point above it.
"""
from __future__ import annotations

from .. import _gl  # noqa: F401  (sets MUJOCO_GL before mujoco is imported)

import collections
import ctypes
import math
import time
from dataclasses import dataclass
from typing import Sequence

import mujoco
import numpy as np

from . import model as PM
from .ik import HOME_Q, IK_SOLVER

IK_ITERS = 30               # a solve stops after this many iterations (a warm-started waypoint needs 2-3; a target
                            # at the edge of the reach creeps on for 100 without getting within REACH_POS)
IK_DAMPING = 1e-4           # mink's Levenberg-Marquardt damping of every IK step
IK_CACHE = 256             # solves remembered per arm (a plan's fixed parts, e.g. the Bounce ball's pick-up, recur)
IK_STALL = 10               # a solve also stops when its best residual has not improved for this many iterations
                            # (an out-of-reach target oscillates about its best for all IK_ITERS otherwise)
POSTURE_COST = 1e-4         # mink posture task towards the home pose (keeps solutions in its family)
MAX_JOINT_JUMP = 0.6        # rad: largest joint change between neighbouring waypoints of a path
IK_POS_TOL = 1e-4           # m: a solve stops this close ...
IK_ORI_TOL = 2e-3           # rad: ... and this close (a path's grasp and release poses) ...
VIA_POS_TOL = 1e-3          # m: ... or this close (the poses the hand passes: the carry's inner waypoints, the
VIA_ORI_TOL = 1e-2          # rad: stand-off path); the servos track them to a few mrad anyway
REACH_POS = 2e-3            # m: a waypoint whose IK residual exceeds this is out of reach ...
REACH_ORI = 0.05            # rad: ... or whose orientation residual exceeds this
WAYPOINT_STEP = 0.1        # m: plans space the hand's waypoints at most this far apart
APPROACH = 0.08             # m: pre-grasp stand-off along the approach direction
VIA_HEIGHT = 0.1            # m: the hand comes down to the stand-off from this far above it
RETREAT = 0.10              # m: after the release the hand backs off this far along -approach


@dataclass
class Carry:
    """One pick-carry-release of the plan.

    Attributes:
        body: name of the body grasped (it must be listed in the env's ``robot_bodies``).
        half_width: half the body's width between the fingers (m).
        path: the grasp site's world poses ``(position, rotation 3x3, z = approach, y = closing axis)``: grasp
            pose first, release pose last. The body point at the first position (before anything moves) is the
            held point; closed-loop correction puts it at the last position.
        latch: a tool joint the arm turns (free while held, locked where the arm leaves it), or ``None``.
        retreat: how far the hand backs off along -approach after the release (m; not after the last step).
        alternatives: other paths for the same step, tried in order if ``path`` is out of reach.
        fingers_only: until the release the body touches only the fingers (the pendulum bob, which hangs 0.5 mm
            behind the object at rest: a grasp there would nudge the object); its own contacts are back from the
            release on.
        fixed_start: the step picks the body where it rests at reset, the same for every action (the Bounce ball on
            its table, the Bridge plank at its rest yaw): the arm then waits between attempts at this step's
            stand-off (:meth:`~phyplan_envs.panda.robot.RobotArm.ready_above`) instead of above it.
        hold_tol: closed-loop release accuracy of the held point (m); ``None``: the controller's ``HOLD_TOL``.
    """

    body: str
    half_width: float
    path: Sequence[tuple[np.ndarray, np.ndarray]]
    latch: str | None = None
    retreat: float = RETREAT
    alternatives: Sequence[Sequence[tuple[np.ndarray, np.ndarray]]] = ()
    fingers_only: bool = False
    fixed_start: bool = False
    hold_tol: float | None = None


class RobotFailure(Exception):
    """The plan cannot be carried out (out of reach, failed grasp); the attempt goes on without it."""


class IKStep:
    """One iteration of the arm's differential IK: ``mink.solve_ik(cfg, [frame, posture], 1.0, "daqp",
    damping=damping, limits=[limit])``, bit for bit (a test checks it), at well under half its cost.

    The same arithmetic in one function, with the same operations in the same order: the frame task's error and
    Jacobian from mink's own compiled Lie-group operations (``mink.lie._lie_ops_c``, which mink's ``FrameTask`` and
    ``Configuration`` call), the posture task's error by ``mj_differentiatePos`` and its Jacobian (the identity)
    weighted once, and mink's joint-limit rows built once: every joint of the IK model is a limited hinge, so
    ``limit``'s inequality is the constant ``[P; -P] dq <= [gain (upper - q); gain (q - lower)]`` (mink builds it from
    ``mj_differentiatePos``, which for a hinge is that difference). The QP goes to DAQP (the solver mink's dependency
    ``qpsolvers[daqp]`` installs) as qpsolvers would pass it, without qpsolvers' problem checks and dispatch."""

    def __init__(self, cfg, frame, posture, limit, damping: float):
        try:                 # mink's compiled Lie-group operations (its FrameTask falls back to Python without them)
            from mink.lie import _lie_ops_c
        except ImportError:
            _lie_ops_c = None

        m = cfg.model
        if m.nq != m.nv or not all(int(t) == mujoco.mjtJoint.mjJNT_HINGE for t in m.jnt_type) \
                or not np.all(m.jnt_limited) or m.neq:
            raise ValueError("IKStep: the IK model must have limited hinge joints only")
        if posture._v_ids is not None or frame.frame_type != "site":
            raise ValueError("IKStep: a posture task over every joint and a frame task on a site")
        self.cfg, self.frame, self.posture, self.limit, self.damping = cfg, frame, posture, limit, damping
        self._lie = _lie_ops_c
        self._site = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_SITE, frame.frame_name)
        self._G = np.vstack([limit.projection_matrix, -limit.projection_matrix])
        n = self._G.shape[0]
        self._lower_bound = np.full(n, -1e30)
        self._sense = np.zeros(n, dtype=ctypes.c_int)
        self._W = np.empty((6 + m.nv, m.nv))                    # [frame; posture] weighted Jacobians
        self._W[6:] = posture.cost[:, None] * np.eye(m.nv)     # the posture task's (constant)
        self._e = np.empty(6 + m.nv)
        self._jac = np.empty((6, m.nv))
        self._qvel = np.empty(m.nv)
        idx = limit.indices
        self._upper, self._lower = limit.upper[idx], limit.lower[idx]   # (upper - q)[idx] = upper[idx] - q[idx]
        self._h = np.empty(2 * len(idx))

    def __call__(self) -> np.ndarray:
        """The joint velocity of one step from the configuration's current pose (``mink.NoSolutionFound`` if the
        QP has none)."""
        import daqp
        import mink

        cfg, lim, frame, posture, lie = self.cfg, self.limit, self.frame, self.posture, self._lie
        m, d = cfg.model, cfg.data
        # FrameTask.compute_qp_residual: error and Jacobian at the frame's pose, then Task._weighted_residual
        W, e = self._W, self._e                # mink's _compute_qp_objective stacks [frame; posture] in this order
        if lie is None:                        # no compiled operations: mink's own (Python) frame task
            W1, e1, mu1 = frame.compute_qp_residual(cfg)
            W[:6], e[:6] = W1, e1
        else:
            xmat, xpos = d.site_xmat[self._site], d.site_xpos[self._site]
            pose = lie.xmat_xpos_to_wxyz_xyz(xmat, xpos)
            jac = self._jac
            mujoco.mj_jacSite(m, d, jac[:3], jac[3:], self._site)
            jac = lie.se3_rotation_adjoint_from_xmat(xmat) @ jac
            target = frame.transform_target_to_world.wxyz_xyz
            error = lie.se3_rminus(target, pose)
            J1 = -lie.se3_jlog(lie.se3_inverse_multiply(target, pose)) @ jac
            np.multiply(frame.cost, -frame.gain * error, out=e[:6])
            np.multiply(frame.cost[:, None], J1, out=W[:6])
            e1 = e[:6]
            mu1 = frame.lm_damping * float(e1 @ e1)
        # PostureTask: error q - target (mj_differentiatePos), Jacobian the identity
        qvel = self._qvel
        q = d.qpos
        mujoco.mj_differentiatePos(m, qvel, 1.0, posture.target_q, q)
        np.multiply(posture.cost, -posture.gain * qvel, out=e[6:])
        e2 = e[6:]
        mu2 = posture.lm_damping * float(e2 @ e2)
        H = W.T @ W
        c = -(e @ W)
        H.flat[:: H.shape[0] + 1] += self.damping + (0.0 + mu1 + mu2)
        h, n = self._h, len(self._upper)
        np.multiply(lim.gain, self._upper - q, out=h[:n])
        np.multiply(lim.gain, q - self._lower, out=h[n:])
        x, _, flag, _ = daqp.solve(H, c, self._G, h, self._lower_bound, self._sense)
        if flag <= 0:
            raise mink.NoSolutionFound("daqp")
        return x / 1.0


class ArmIK:
    """Warm-started mink IK of the Panda standing at world ``base_pos`` turned by ``base_yaw``."""

    def __init__(self, base_pos, base_yaw: float):
        self.base_pos = np.asarray(base_pos, dtype=np.float64)
        c, s = math.cos(base_yaw), math.sin(base_yaw)
        self._R = np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])
        self._ik_model = PM.ik_model()
        self._ik_site = mujoco.mj_name2id(self._ik_model, mujoco.mjtObj.mjOBJ_SITE, PM.GRASP_SITE)
        self._mink = None
        self._fk = None          # MjData of the IK model for forward kinematics
        self.solves = 0       # IK problems solved (every waypoint of every plan, a remembered one too)
        self._cache: collections.OrderedDict = collections.OrderedDict()
        self.timer = None       # a stage timer (stage, seconds, steps): every solve reported as "ik"

    def to_base(self, pos, rot) -> tuple[np.ndarray, np.ndarray]:
        return self._R.T @ (np.asarray(pos, dtype=np.float64) - self.base_pos), self._R.T @ np.asarray(rot)

    def solve(self, q0, pos, rot, pos_tol: float = IK_POS_TOL, iters: int = IK_ITERS,
              ori_tol: float = IK_ORI_TOL) -> tuple[np.ndarray, float, float]:
        """Joint angles putting the grasp site at world ``pos`` with world rotation ``rot``, starting from ``q0``
        (mink differential IK, posture pulled towards ``q0``); and the position / orientation residuals. A solve
        stops within IK_POS_TOL / IK_ORI_TOL, or when its best residual has not improved for IK_STALL iterations."""
        if self.timer is None:
            return self._remembered(q0, pos, rot, pos_tol, iters, ori_tol)
        t = time.process_time()
        try:
            return self._remembered(q0, pos, rot, pos_tol, iters, ori_tol)
        finally:
            self.timer("ik", time.process_time() - t, 0)

    def _remembered(self, q0, pos, rot, pos_tol, iters, ori_tol) -> tuple[np.ndarray, float, float]:
        self.solves += 1
        q0 = np.asarray(q0, dtype=np.float64)
        pos = np.asarray(pos, dtype=np.float64)
        rot = np.asarray(rot, dtype=np.float64)
        # a solve is a pure function of its inputs (mink and its QP keep no state between solves): the same problem
        # again returns the remembered answer, bit for bit
        key = (q0.tobytes(), pos.tobytes(), rot.tobytes(), pos_tol, iters, ori_tol)
        hit = self._cache.get(key)
        if hit is not None:
            self._cache.move_to_end(key)
            return hit[0].copy(), hit[1], hit[2]
        q, pe, oe = self._solve(q0, pos, rot, pos_tol, iters, ori_tol)
        self._cache[key] = (q.copy(), pe, oe)
        if len(self._cache) > IK_CACHE:
            self._cache.popitem(last=False)
        return q, pe, oe

    def _solve(self, q0, pos, rot, pos_tol: float, iters: int, ori_tol: float) -> tuple[np.ndarray, float, float]:
        import mink

        pb, rb = self.to_base(pos, rot)
        if self._mink is None:
            m = self._ik_model
            self._mink = (mink.Configuration(m), mink.FrameTask(PM.GRASP_SITE, "site", position_cost=1.0,
                                                                 orientation_cost=0.5, lm_damping=1e-3),
                          mink.PostureTask(m, cost=POSTURE_COST), [mink.ConfigurationLimit(m)])
            # mink.solve_ik first checks the configuration against the joint limits, only to log a warning (the QP's
            # ConfigurationLimit enforces them): ~10% of an IK iteration, skipped on this configuration
            self._mink[0].check_limits = lambda *args, **kwargs: None
            self._step = IKStep(*self._mink[:3], self._mink[3][0], IK_DAMPING)
        cfg, frame, posture, limits = self._mink
        cfg.update(np.asarray(q0, dtype=np.float64))
        frame.set_target(mink.SE3.from_rotation_and_translation(mink.SO3.from_matrix(rb), pb))
        posture.set_target(self.home_towards(pos))      # keeps the arm in the home pose's family of solutions
        best = None
        for it in range(iters):
            pe, oe = self._residuals(cfg.data, pb, rb)
            if best is None or pe + 0.05 * oe < best[0]:
                best = (pe + 0.05 * oe, cfg.q.copy(), pe, oe)
                best_it = it
            if pe < pos_tol and oe < ori_tol:
                break
            if it - best_it >= IK_STALL:
                break
            try:
                v = self._step()      # = mink.solve_ik(cfg, [frame, posture], 1.0, IK_SOLVER, IK_DAMPING, limits)
            except mink.NoSolutionFound:
                break
            if np.max(np.abs(v)) < 1e-8:
                break
            cfg.integrate_inplace(v, 1.0)
        else:
            pe, oe = self._residuals(cfg.data, pb, rb)
            if pe + 0.05 * oe < best[0]:
                best = (pe + 0.05 * oe, cfg.q.copy(), pe, oe)
        return best[1], best[2], best[3]

    def _residuals(self, data, pos, rot) -> tuple[float, float]:
        d = data.site_xpos[self._ik_site] - pos
        c = (np.trace(rot.T @ data.site_xmat[self._ik_site].reshape(3, 3)) - 1.0) / 2.0
        return math.sqrt(d @ d), math.acos(min(1.0, max(-1.0, c)))   # (numpy's norm of a vector: sqrt(d @ d))

    def home_towards(self, pos) -> np.ndarray:
        pb = self._R.T @ (np.asarray(pos) - self.base_pos)
        q = np.array(HOME_Q, dtype=np.float64)
        q[0] = math.atan2(pb[1], pb[0])
        return q

    def forward(self, q) -> tuple[np.ndarray, np.ndarray]:
        """World position and rotation of the grasp site at joint angles ``q``."""
        if self._fk is None:
            self._fk = mujoco.MjData(self._ik_model)
        self._fk.qpos[:] = q
        mujoco.mj_kinematics(self._ik_model, self._fk)
        x = self._fk.site_xpos[self._ik_site]
        return self._R @ x + self.base_pos, self._R @ self._fk.site_xmat[self._ik_site].reshape(3, 3)

    def closest_approach(self, qs, point, samples: int = 10) -> float:
        """How near the grasp site comes to world ``point`` along the joint-space polyline ``qs`` (sampled)."""
        best = math.inf
        point = np.asarray(point, dtype=np.float64)
        for a, b in zip(qs[:-1], qs[1:]):
            a, b = np.asarray(a), np.asarray(b)
            for k in range(samples + 1):
                d = self.forward(a + (b - a) * (k / samples))[0] - point
                best = min(best, math.sqrt(d @ d))
        return best

    def joint_path(self, q0, poses, what: str, exact=()) -> list[np.ndarray]:
        """Warm-started IK through ``poses`` (world); :class:`RobotFailure` if one is out of reach. The poses whose
        indices are in ``exact`` are solved to IK_POS_TOL / IK_ORI_TOL, the others (points the hand passes) to
        VIA_POS_TOL / VIA_ORI_TOL."""
        qs, q = [], np.asarray(q0, dtype=np.float64)
        for k, (pos, rot) in enumerate(poses):
            q_prev = q
            tol = {} if k in exact else {"pos_tol": VIA_POS_TOL, "ori_tol": VIA_ORI_TOL}
            q, pe, oe = self.solve(q_prev, pos, rot, **tol)
            if pe > REACH_POS or oe > REACH_ORI:     # a local minimum of the warm start: from the home pose again
                q2, pe2, oe2 = self.solve(self.home_towards(pos), pos, rot, **tol)
                if pe2 <= REACH_POS and oe2 <= REACH_ORI and np.max(np.abs(q2 - q_prev)) < MAX_JOINT_JUMP:
                    q, pe, oe = q2, pe2, oe2
            if pe > REACH_POS or oe > REACH_ORI:
                raise RobotFailure(f"unreachable: {what} waypoint {k + 1}/{len(poses)} at "
                                   f"({pos[0]:.3f}, {pos[1]:.3f}, {pos[2]:.3f}) m misses by {pe * 1e3:.1f} mm, "
                                   f"{math.degrees(oe):.1f} deg")
            qs.append(q)
        return qs

    def plan(self, step: Carry, q_from=None):
        """Joint waypoints for the first of ``step.path`` and ``step.alternatives`` that the arm reaches all along
        (nothing moves before): the grasp warm-started from ``q_from`` (the arm's joints now: the grasp nearest them,
        so the arm does not swing its wrist or elbow around on the way; the controller passes its ready pose for a
        plan's first step) or, without it or for a ``fixed_start`` step (whose stand-off is the ready pose itself),
        from the home pose turned towards it; then warm-started along the path and back out to the pre-grasp
        stand-off. The grasp and release poses are solved to IK_POS_TOL / IK_ORI_TOL, the rest to VIA_POS_TOL /
        VIA_ORI_TOL; if the grasp nearest ``q_from`` does not reach along the path, the home pose's is tried."""
        first = None
        for cand in [step.path, *step.alternatives]:
            path = [(np.asarray(p, dtype=np.float64), np.asarray(r, dtype=np.float64)) for p, r in cand]
            grasp_pos, grasp_rot = path[0]
            home = self.home_towards(grasp_pos)
            starts = [home] if q_from is None or step.fixed_start else [q_from, home]
            try:
                q_path = self._carry_path(path, starts)
                stand_off = [(grasp_pos - f * APPROACH * grasp_rot[:, 2], grasp_rot) for f in (0.25, 0.5, 0.75, 1.0)]
                via = (stand_off[-1][0] + np.array([0.0, 0.0, VIA_HEIGHT]), grasp_rot)
                q_app = self.joint_path(q_path[0], stand_off + [via], "pre-grasp")[::-1]
            except RobotFailure as e:
                first = first or e
                continue
            return path, q_app, q_path[0], q_path[1:]
        raise first

    def _carry_path(self, path, starts) -> list[np.ndarray]:
        """The joint path along ``path`` from the first of ``starts`` that reaches all along it (grasp and release
        solved exactly); the last start's :class:`RobotFailure` if none does."""
        for k, q0 in enumerate(starts):
            try:
                return self.joint_path(q0, path, "carry", exact=(0, len(path) - 1))
            except RobotFailure:
                if k == len(starts) - 1:
                    raise
