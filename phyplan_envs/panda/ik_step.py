"""One iteration of mink's differential IK on the Panda's chain, re-implemented: :class:`IKStep`.

``mink.solve_ik`` with a frame task on the grasp site, a posture task and the joint limits, the same arithmetic bit
for bit at about a third of its cost (both IK solvers of :mod:`phyplan_envs.panda.ik` iterate with it; a test
compares it with mink's).
"""
from __future__ import annotations

from .. import _gl  # noqa: F401  (sets MUJOCO_GL before mujoco is imported)

import ctypes

import mujoco
import numpy as np


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
