"""Inverse kinematics of the Panda with mink: the one IK module of the posed visual arm and of robot mode's arm.

Written once here and used by both: the chain (:func:`phyplan_envs.panda.model.ik_model`, its 7 arm joints and
limits, the grasp site) and the Panda's base frame (:class:`ArmChain`: world <-> base, forward kinematics), the
residuals of a grasp-site pose (:func:`residuals`), the tolerances (:data:`IK_POS_TOL` / :data:`IK_ORI_TOL` a solve
stops at, :data:`REACH_POS` / :data:`REACH_ORI` a pose counts as reached within), the home posture :data:`HOME_Q`
turned towards a target (:func:`home_towards`), and the mink problem (:class:`MinkProblem`: a frame task on the grasp
site, a posture task towards the home pose, the joint limits) with its iteration :class:`IKStep` (mink's
``solve_ik`` bit for bit, at about a third of its cost; in :mod:`phyplan_envs.panda.ik_step`, re-exported here).

Two entry points, because the two arms need two algorithms:

* :class:`PandaIK` (the posed visual arm, :mod:`phyplan_envs.panda.posed`): a fresh solve for every request, always
  from the home pose turned towards the target, up to :data:`IK_MAX_ITERS` iterations, the grasp candidates tried in
  turn and a loose re-solve when none is reached (:meth:`PandaIK.solve_grasp`). It has no joint state to start from
  (a render shows one pose, not a motion), so a pose is a pure function of its rounded request, cached per process
  (:func:`shared_ik`, keyed by the target rounded to 0.1 mm and the orientation in the base frame): every render of
  the same action draws the same arm, whatever was drawn before.
* :class:`ArmIK` (robot mode's arm, :mod:`phyplan_envs.panda.robot`): warm-started from given joint angles (the
  previous waypoint of a path, the arm's joints now) with a light posture task, so that neighbouring waypoints stay
  on one branch of solutions and the arm does not swing its wrist or elbow around between them; short solves
  (:data:`WARM_ITERS`, stopped when the best residual stalls for :data:`WARM_STALL` iterations) to a tolerance per
  waypoint, remembered per arm on the exact inputs. Path planning on top of it (reach checks, the restart from the
  home pose, the joint-jump limit) is :mod:`phyplan_envs.panda.robot.paths`.

Targets are world poses for :class:`ArmIK` and base-frame poses for :class:`PandaIK` (one solver serves every
scene's Panda). Out-of-reach targets are not an error: the solvers return the closest pose they find and its
residuals.
"""
from __future__ import annotations

from .. import _gl  # noqa: F401  (sets MUJOCO_GL before mujoco is imported)

import collections
import functools
import math
import time
from dataclasses import dataclass

import mujoco
import numpy as np

from .grasp import grasp_rotation, yaw_matrix
from .ik_step import IKStep
from .model import GRASP_SITE, ik_model

# --- shared by both solvers -------------------------------------------------------------------------------------------
# A ready pose of this chain: the hand points straight down in front of the base (link6/link7 in chain.xml carry
# the +pi/2 and +pi/4 offsets that the usual Panda "home" puts in joints 6 and 7, so those are 0 here).
HOME_Q = (0.0, -0.785, 0.0, -2.356, 0.0, 0.0, 0.0)
IK_SOLVER = "daqp"         # the QP backend mink uses (installed with it; IKStep calls it directly)
IK_DAMPING = 1e-4          # mink's Levenberg-Marquardt damping of every IK step
FRAME_LM_DAMPING = 1e-3    # the frame task's own (error-scaled) damping
ORIENTATION_COST = 0.5     # the frame task's orientation cost (position cost 1)
ORI_WEIGHT = 0.05          # m/rad: a pose's score is position residual + ORI_WEIGHT * orientation residual
IK_POS_TOL = 1e-4          # m: a solve stops when the grasp site is this close to the target ...
IK_ORI_TOL = 2e-3          # rad: ... and this close to the target orientation
REACH_POS = 2e-3           # m: a pose is reached when its position residual is within this ...
REACH_ORI = 0.05           # rad: ... and its orientation residual within this
# --- PandaIK: fresh solves (the posed arm) ----------------------------------------------------------------------------
IK_MAX_ITERS = 150
IK_POSTURE_COST = 1e-3     # posture task towards the home pose
IK_ACCEPT_POS = REACH_POS  # m: the first candidate grasp within these residuals is taken; otherwise the best
IK_ACCEPT_ORI = REACH_ORI  # rad
LOOSE_ORIENTATION_COST = 0.02   # the re-solve for the closest reachable point when no candidate is reached
IK_CACHE_SIZE = 4096
# --- ArmIK: warm-started solves (robot mode) --------------------------------------------------------------------------
WARM_ITERS = 30            # a solve stops after this many iterations (a warm-started waypoint needs 2-3; a target
                           # at the edge of the reach creeps on for 100 without getting within REACH_POS)
WARM_STALL = 10            # a solve also stops when its best residual has not improved for this many iterations
                           # (an out-of-reach target oscillates about its best for all WARM_ITERS otherwise)
WARM_POSTURE_COST = 1e-4   # posture task towards the home pose turned to the target (keeps solutions in its family)
WARM_CACHE_SIZE = 256      # solves remembered per arm (a plan's fixed parts, e.g. the Bounce ball's pick-up, recur)


# ================================================================================================= the shared parts
def residuals(p, r, pos, rot) -> tuple[float, float]:
    """Position (m) and orientation (rad) residuals of the grasp-site pose ``(p, r)`` from the target ``(pos, rot)``
    (rotation matrices; the orientation residual is the angle of ``rot^T r``)."""
    d = p - pos
    c = (np.trace(rot.T @ r) - 1.0) / 2.0
    return math.sqrt(d @ d), math.acos(min(1.0, max(-1.0, c)))   # (numpy's norm of a vector: sqrt(d @ d))


def home_towards(point_base) -> np.ndarray:
    """:data:`HOME_Q` with the base joint turned towards ``point_base`` (the Panda's base frame)."""
    q = np.array(HOME_Q, dtype=np.float64)
    q[0] = math.atan2(point_base[1], point_base[0])
    return q


class ArmChain:
    """The IK chain (:func:`ik_model`) of a Panda standing at world ``base_pos`` turned by ``base_yaw``: the base
    frame, forward kinematics (on one scratch ``MjData``) and the grasp site's residuals."""

    def __init__(self, base_pos=(0.0, 0.0, 0.0), base_yaw: float = 0.0):
        self.model = ik_model()
        self.site = mujoco.mj_name2id(self.model, mujoco.mjtObj.mjOBJ_SITE, GRASP_SITE)
        self.base_pos = np.asarray(base_pos, dtype=np.float64)
        self.R = yaw_matrix(base_yaw)
        self._data = None

    def to_base(self, point) -> np.ndarray:
        """A world point in the base frame."""
        return self.R.T @ (np.asarray(point, dtype=np.float64) - self.base_pos)

    def kinematics(self, q) -> mujoco.MjData:
        """The chain's scratch data after forward kinematics at joint angles ``q`` (overwritten by the next call)."""
        if self._data is None:
            self._data = mujoco.MjData(self.model)
        self._data.qpos[:] = q
        mujoco.mj_kinematics(self.model, self._data)
        return self._data

    def site_residuals(self, data: mujoco.MjData, pos, rot) -> tuple[float, float]:
        """:func:`residuals` of the grasp site in ``data`` (this chain's) from a base-frame target."""
        return residuals(data.site_xpos[self.site], data.site_xmat[self.site].reshape(3, 3), pos, rot)

    def home_towards(self, point) -> np.ndarray:
        """:data:`HOME_Q` with the base joint turned towards the world ``point``."""
        return home_towards(self.to_base(point))


class MinkProblem:
    """mink's differential-IK problem on a chain model: a frame task on the grasp site (position cost 1), a posture
    task over every joint and the joint limits, in one reusable ``mink.Configuration``; :attr:`step` is its
    iteration (:class:`IKStep`)."""

    def __init__(self, model: mujoco.MjModel, posture_cost: float, orientation_cost: float = ORIENTATION_COST):
        import mink

        self._mink = mink
        self.cfg = mink.Configuration(model)
        self.frame = mink.FrameTask(GRASP_SITE, "site", position_cost=1.0, orientation_cost=orientation_cost,
                                    lm_damping=FRAME_LM_DAMPING)
        self.posture = mink.PostureTask(model, cost=posture_cost)
        self.limits = [mink.ConfigurationLimit(model)]
        # mink.solve_ik first checks the configuration against the joint limits, only to log a warning (the QP's
        # ConfigurationLimit enforces them): skipped on this configuration
        self.cfg.check_limits = lambda *args, **kwargs: None
        self.step = IKStep(self.cfg, self.frame, self.posture, self.limits[0], IK_DAMPING)

    def start(self, q0, pos, rot, posture_q) -> None:
        """The configuration at ``q0``, the frame task's target ``(pos, rot)`` and the posture's ``posture_q``."""
        mink = self._mink
        self.cfg.update(q0)
        self.frame.set_target(mink.SE3.from_rotation_and_translation(mink.SO3.from_matrix(rot), pos))
        self.posture.set_target(posture_q)


# ================================================================================================ the posed arm's IK
@dataclass(frozen=True)
class IKSolution:
    """Joint angles (rad, joints 1-7) and how far the grasp site ends from the requested pose."""

    q: np.ndarray
    position_residual: float      # m
    orientation_residual: float   # rad
    iterations: int


class PandaIK:
    """Fresh-start IK for the posed arm: deterministic (always starts from :data:`HOME_Q` turned towards the target)
    and cached per process on the rounded request. Targets are in the Panda's base frame; an out-of-reach target gets
    the closest pose found (position weighted above orientation) and its residuals."""

    def __init__(self):
        import mink

        self._mink = mink
        self.chain = ArmChain()
        self.model = self.chain.model
        self._home = np.array(HOME_Q, dtype=np.float64)
        self._low = self.model.jnt_range[:, 0].copy()
        self._high = self.model.jnt_range[:, 1].copy()
        self._problems: dict[float, MinkProblem] = {}      # per orientation cost
        self._cache: collections.OrderedDict[tuple, IKSolution] = collections.OrderedDict()
        self.solves = 0      # IK problems actually solved (not served from the cache)

    def _start(self, pos: np.ndarray) -> np.ndarray:
        q = home_towards(pos)
        q[0] = float(np.clip(q[0], self._low[0], self._high[0]))
        return q

    def _problem(self, orientation_cost: float) -> MinkProblem:
        if orientation_cost not in self._problems:
            self._problems[orientation_cost] = MinkProblem(self.model, IK_POSTURE_COST, orientation_cost)
        return self._problems[orientation_cost]

    def solve(self, pos, rot, orientation_cost: float = ORIENTATION_COST) -> IKSolution:
        """Joint angles that put the grasp site at ``pos`` (m) with orientation ``rot`` (3x3), base frame."""
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
        sol = self._fresh_solve(pos, rot, self._problem(orientation_cost))
        self.solves += 1
        self._cache[key] = sol
        if len(self._cache) > IK_CACHE_SIZE:
            self._cache.popitem(last=False)
        return sol

    def _fresh_solve(self, pos, rot, problem: MinkProblem) -> IKSolution:
        problem.start(self._start(pos), pos, rot, self._home)
        config, chain = problem.cfg, self.chain
        best = None
        it = 0
        for it in range(1, IK_MAX_ITERS + 1):
            try:
                v = problem.step()    # = mink.solve_ik(config, [frame, posture], 1.0, IK_SOLVER, IK_DAMPING, limits)
            except self._mink.NoSolutionFound:    # an infeasible QP step: keep the best pose found so far
                break
            config.integrate_inplace(v, 1.0)
            pe, oe = chain.site_residuals(config.data, pos, rot)
            score = pe + ORI_WEIGHT * oe
            if best is None or score < best[0] - 1e-9:
                best = (score, config.q.copy(), pe, oe)
            if pe < IK_POS_TOL and oe < IK_ORI_TOL:
                break
            if np.max(np.abs(v)) < 1e-7:    # converged to the closest reachable pose
                break
        if best is None:                    # not even one step: the start pose
            pe, oe = chain.site_residuals(config.data, pos, rot)
            best = (0.0, config.q.copy(), pe, oe)
        _, q, pe, oe = best
        return IKSolution(np.clip(q, self._low, self._high), float(pe), float(oe), it)

    def forward(self, q) -> tuple[np.ndarray, np.ndarray]:
        """Grasp-site position and rotation matrix (base frame) for joint angles ``q``."""
        d, site = self.chain.kinematics(q), self.chain.site
        return d.site_xpos[site].copy(), d.site_xmat[site].reshape(3, 3).copy()

    def solve_grasp(self, pos, candidates) -> tuple[IKSolution, int]:
        """The first candidate orientation (base frame) reached within the acceptance residuals, else the best."""
        best = None
        for i, rot in enumerate(candidates):
            sol = self.solve(pos, rot)
            if sol.position_residual < IK_ACCEPT_POS and sol.orientation_residual < IK_ACCEPT_ORI:
                return sol, i
            score = sol.position_residual + ORI_WEIGHT * sol.orientation_residual
            if best is None or score < best[0]:
                best = (score, sol, i)
        # none is good: the closest reachable point, position first (orientation barely weighted)
        _, sol, i = best
        if sol.position_residual >= IK_ACCEPT_POS:
            loose = self.solve(pos, candidates[i], orientation_cost=LOOSE_ORIENTATION_COST)
            if loose.position_residual < sol.position_residual:
                sol = loose
        return sol, i


@functools.lru_cache(maxsize=1)
def shared_ik() -> PandaIK:
    """The per-process IK solver (and its cache) that every Panda handle uses."""
    return PandaIK()


# ================================================================================================ robot mode's IK
class ArmIK:
    """Warm-started mink IK of the Panda standing at world ``base_pos`` turned by ``base_yaw`` (robot mode)."""

    def __init__(self, base_pos, base_yaw: float):
        self.chain = ArmChain(base_pos, base_yaw)
        self.base_pos = self.chain.base_pos
        self.problem = None      # the MinkProblem, built at the first solve
        self.solves = 0       # IK problems solved (every waypoint of every plan, a remembered one too)
        self._cache: collections.OrderedDict = collections.OrderedDict()
        self.timer = None       # a stage timer (stage, seconds, steps): every solve reported as "ik"

    def to_base(self, pos, rot) -> tuple[np.ndarray, np.ndarray]:
        return self.chain.to_base(pos), self.chain.R.T @ np.asarray(rot)

    def home_towards(self, pos) -> np.ndarray:
        """:data:`HOME_Q` with the base joint turned towards the world point ``pos``."""
        return self.chain.home_towards(pos)

    def solve(self, q0, pos, rot, pos_tol: float = IK_POS_TOL, iters: int = WARM_ITERS,
              ori_tol: float = IK_ORI_TOL) -> tuple[np.ndarray, float, float]:
        """Joint angles putting the grasp site at world ``pos`` with world rotation ``rot``, starting from ``q0``
        (posture pulled towards the home pose turned to the target); and the position / orientation residuals. A
        solve stops within ``pos_tol`` / ``ori_tol``, or when its best residual has not improved for WARM_STALL
        iterations."""
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
        q, pe, oe = self._warm_solve(q0, pos, rot, pos_tol, iters, ori_tol)
        self._cache[key] = (q.copy(), pe, oe)
        if len(self._cache) > WARM_CACHE_SIZE:
            self._cache.popitem(last=False)
        return q, pe, oe

    def _warm_solve(self, q0, pos, rot, pos_tol, iters, ori_tol) -> tuple[np.ndarray, float, float]:
        import mink

        pb, rb = self.to_base(pos, rot)
        if self.problem is None:
            self.problem = MinkProblem(self.chain.model, WARM_POSTURE_COST)
        problem, chain = self.problem, self.chain
        cfg = problem.cfg
        # the posture towards the home pose turned to the target keeps the arm in its family of solutions
        problem.start(np.asarray(q0, dtype=np.float64), pb, rb, self.home_towards(pos))
        best = None
        for it in range(iters):
            pe, oe = chain.site_residuals(cfg.data, pb, rb)
            if best is None or pe + ORI_WEIGHT * oe < best[0]:
                best = (pe + ORI_WEIGHT * oe, cfg.q.copy(), pe, oe)
                best_it = it
            if pe < pos_tol and oe < ori_tol:
                break
            if it - best_it >= WARM_STALL:
                break
            try:
                v = problem.step()    # = mink.solve_ik(cfg, [frame, posture], 1.0, IK_SOLVER, IK_DAMPING, limits)
            except mink.NoSolutionFound:
                break
            if np.max(np.abs(v)) < 1e-8:
                break
            cfg.integrate_inplace(v, 1.0)
        else:
            pe, oe = chain.site_residuals(cfg.data, pb, rb)
            if pe + ORI_WEIGHT * oe < best[0]:
                best = (pe + ORI_WEIGHT * oe, cfg.q.copy(), pe, oe)
        return best[1], best[2], best[3]

    def forward(self, q) -> tuple[np.ndarray, np.ndarray]:
        """World position and rotation of the grasp site at joint angles ``q``."""
        chain = self.chain
        d = chain.kinematics(q)
        x = d.site_xpos[chain.site]
        return chain.R @ x + chain.base_pos, chain.R @ d.site_xmat[chain.site].reshape(3, 3)
