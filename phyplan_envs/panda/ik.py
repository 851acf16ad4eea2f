"""Inverse kinematics of the Panda with mink: joint angles that put the grasp site at a pose, deterministic, cached.

:class:`PandaIK` solves on :func:`phyplan_envs.panda.model.ik_model` in the Panda's base frame; :func:`shared_ik`
is the one solver per process whose cache every scene's Panda shares (keyed by the target rounded to 0.1 mm and the
orientation), so repeated renders of the same pose cost one dictionary look-up.
"""
from __future__ import annotations

from .. import _gl  # noqa: F401  (sets MUJOCO_GL before mujoco is imported)

import functools
import math
from collections import OrderedDict
from dataclasses import dataclass

import mujoco
import numpy as np

from .grasp import grasp_rotation
from .model import GRASP_SITE, ik_model

# --- inverse kinematics -----------------------------------------------------------------------------------------------
# A ready pose of this chain: the hand points straight down in front of the base (link6/link7 in chain.xml carry
# the +pi/2 and +pi/4 offsets that the usual Panda "home" puts in joints 6 and 7, so those are 0 here).
HOME_Q = (0.0, -0.785, 0.0, -2.356, 0.0, 0.0, 0.0)
IK_SOLVER = "daqp"         # the QP backend mink uses (installed with it)
IK_MAX_ITERS = 150
IK_POS_TOL = 1e-4          # m: a solve stops when the grasp site is this close to the target ...
IK_ORI_TOL = 2e-3          # rad: ... and this close to the target orientation
IK_ACCEPT_POS = 2e-3       # m: the first candidate grasp within these residuals is taken; otherwise the best
IK_ACCEPT_ORI = 0.05       # rad
IK_CACHE_SIZE = 4096


@dataclass(frozen=True)
class IKSolution:
    """Joint angles (rad, joints 1-7) and how far the grasp site ends from the requested pose."""

    q: np.ndarray
    position_residual: float      # m
    orientation_residual: float   # rad
    iterations: int


class PandaIK:
    """Differential IK with mink on :func:`ik_model`; deterministic (always starts from :data:`HOME_Q` turned
    towards the target) and cached per process on the rounded request.

    Targets are in the Panda's base frame. Out-of-reach targets are not an error: the solver returns the closest
    pose it finds (position weighted above orientation) and its residuals.
    """

    def __init__(self):
        import mink

        self._mink = mink
        self.model = ik_model()
        self._home = np.array(HOME_Q, dtype=np.float64)
        self._low = self.model.jnt_range[:, 0].copy()
        self._high = self.model.jnt_range[:, 1].copy()
        self._site = mujoco.mj_name2id(self.model, mujoco.mjtObj.mjOBJ_SITE, GRASP_SITE)
        self._cache: OrderedDict[tuple, IKSolution] = OrderedDict()
        self.solves = 0      # IK problems actually solved (not served from the cache)

    def _start(self, pos: np.ndarray) -> np.ndarray:
        q = self._home.copy()
        q[0] = float(np.clip(math.atan2(pos[1], pos[0]), self._low[0], self._high[0]))
        return q

    def solve(self, pos, rot, orientation_cost: float = 0.5) -> IKSolution:
        """Joint angles that put the grasp site at ``pos`` (m) with orientation ``rot`` (3x3), base frame."""
        mink = self._mink
        pos = np.asarray(pos, dtype=np.float64)
        rot = np.asarray(rot, dtype=np.float64)
        if pos.shape != (3,) or rot.shape != (3, 3) or not (np.all(np.isfinite(pos)) and np.all(np.isfinite(rot))):
            raise ValueError(f"IK target must be a finite position (3,) and rotation (3, 3), got {pos!r}, {rot!r}")
        key = (tuple(np.round(pos, 4)), tuple(np.round(rot, 4).ravel()), round(orientation_cost, 4))
        hit = self._cache.get(key)
        if hit is not None:
            self._cache.move_to_end(key)
            return hit
        pos = np.array(key[0])
        rot = grasp_rotation(np.array(key[1]).reshape(3, 3)[:, 2], np.array(key[1]).reshape(3, 3)[:, 1])
        config = mink.Configuration(self.model, self._start(pos))
        frame = mink.FrameTask(GRASP_SITE, "site", position_cost=1.0, orientation_cost=orientation_cost,
                               lm_damping=1e-3)
        frame.set_target(mink.SE3.from_rotation_and_translation(mink.SO3.from_matrix(rot), pos))
        posture = mink.PostureTask(self.model, cost=1e-3)
        posture.set_target(self._home)
        limits = [mink.ConfigurationLimit(self.model)]
        best = None
        it = 0
        for it in range(1, IK_MAX_ITERS + 1):
            try:
                v = mink.solve_ik(config, [frame, posture], 1.0, IK_SOLVER, damping=1e-4, limits=limits)
            except mink.NoSolutionFound:    # an infeasible QP step: keep the best pose found so far
                break
            config.integrate_inplace(v, 1.0)
            pe, oe = self._residuals(config.data, pos, rot)
            score = pe + 0.05 * oe
            if best is None or score < best[0] - 1e-9:
                best = (score, config.q.copy(), pe, oe)
            if pe < IK_POS_TOL and oe < IK_ORI_TOL:
                break
            if np.max(np.abs(v)) < 1e-7:    # converged to the closest reachable pose
                break
        if best is None:                    # not even one step: the start pose
            pe, oe = self._residuals(config.data, pos, rot)
            best = (0.0, config.q.copy(), pe, oe)
        _, q, pe, oe = best
        sol = IKSolution(np.clip(q, self._low, self._high), float(pe), float(oe), it)
        self.solves += 1
        self._cache[key] = sol
        if len(self._cache) > IK_CACHE_SIZE:
            self._cache.popitem(last=False)
        return sol

    def _residuals(self, data: mujoco.MjData, pos: np.ndarray, rot: np.ndarray) -> tuple[float, float]:
        p = data.site_xpos[self._site]
        r = data.site_xmat[self._site].reshape(3, 3)
        pe = float(np.linalg.norm(p - pos))
        c = (np.trace(rot.T @ r) - 1.0) / 2.0
        oe = float(math.acos(min(1.0, max(-1.0, c))))
        return pe, oe

    def forward(self, q) -> tuple[np.ndarray, np.ndarray]:
        """Grasp-site position and rotation matrix (base frame) for joint angles ``q``."""
        data = mujoco.MjData(self.model)
        data.qpos[:] = q
        mujoco.mj_kinematics(self.model, data)
        return data.site_xpos[self._site].copy(), data.site_xmat[self._site].reshape(3, 3).copy()

    def solve_grasp(self, pos, candidates) -> tuple[IKSolution, int]:
        """The first candidate orientation (base frame) reached within the acceptance residuals, else the best."""
        best = None
        for i, rot in enumerate(candidates):
            sol = self.solve(pos, rot)
            if sol.position_residual < IK_ACCEPT_POS and sol.orientation_residual < IK_ACCEPT_ORI:
                return sol, i
            score = sol.position_residual + 0.05 * sol.orientation_residual
            if best is None or score < best[0]:
                best = (score, sol, i)
        # none is good: the closest reachable point, position first (orientation barely weighted)
        _, sol, i = best
        if sol.position_residual >= IK_ACCEPT_POS:
            loose = self.solve(pos, candidates[i], orientation_cost=0.02)
            if loose.position_residual < sol.position_residual:
                sol = loose
        return sol, i


@functools.lru_cache(maxsize=1)
def shared_ik() -> PandaIK:
    """The per-process IK solver (and its cache) that every Panda handle uses."""
    return PandaIK()
