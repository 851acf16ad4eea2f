"""The Panda of one task scene: attached to the scene's MJCF, bound to its compiled physics, posed to hold the tool.

:func:`attach_panda` adds the visual-only copy (:func:`phyplan_envs.panda.posed.scene_copy.panda_mjcf`) to a task's
MJCF root and returns a :class:`PandaHandle`; the env calls ``handle.bind(physics)`` after compiling and
``handle.pose_for(env, action)`` before drawing a frame. Posing solves the joint angles with the shared
:func:`phyplan_envs.panda.ik.shared_ik` and writes every Panda geom's ``geom_pos``/``geom_quat`` from forward
kinematics of the IK chain at them; the physics state is never touched.
"""
from __future__ import annotations

from ... import _gl  # noqa: F401  (sets MUJOCO_GL before mujoco is imported)

import math
from typing import Any

import mujoco
import numpy as np
from dm_control import mjcf

from ... import assets
from ..grasp import grasp_rotation
from ..ik import HOME_Q, ArmChain, IKSolution, residuals, shared_ik
from ..model import (ARM_LINKS, DEFAULT_GRIP_HALF_WIDTH, FINGER_CLEARANCE, FINGER_OPEN, GRASP_SITE, HAND_LINK,
                     PANDA_SITE_GROUP, SHOULDER_HEIGHT)
from .candidates import grasp_candidates
from .scene_copy import _visual_parts, panda_mjcf


class PandaHandle:
    """The Panda attached to one task scene: binds to its compiled physics and poses the arm kinematically.

    Attributes (after :meth:`pose_for` / :meth:`set_pose`):
        q: the 7 arm joint angles (rad) in use.
        finger_opening: each finger's distance from the hand's centre plane (m).
        residual: distance (m) between the grasp point and the requested target (0 when reached; larger when the
            target is out of reach: the arm then gets as close as it can and nothing is raised).
        orientation_residual: angle (rad) between the hand's orientation and the chosen grasp orientation.
        target: the last requested world point.
    """

    def __init__(self, model: mjcf.RootElement, frame: mjcf.Element, base_pos, base_yaw: float):
        self.mjcf_model = model
        self.frame = frame
        self.base_pos = np.asarray(base_pos, dtype=np.float64)
        self.base_yaw = float(base_yaw)
        self.chain = ArmChain(self.base_pos, self.base_yaw)     # the IK chain at this base: frames, kinematics
        self._R = self.chain.R
        self.shoulder = self.base_pos + np.array([0.0, 0.0, SHOULDER_HEIGHT])
        self._bound = False
        self.q = np.array(HOME_Q, dtype=np.float64)
        self.finger_opening = FINGER_OPEN
        self.residual = float("nan")
        self.orientation_residual = float("nan")
        self.target: np.ndarray | None = None

    # ---------------------------------------------------------------------------------------------------- binding
    def bind(self, physics: mjcf.Physics) -> None:
        """Find the Panda's geoms and grasp site in the compiled ``physics``; remember their poses in their links."""
        self.model: mujoco.MjModel = physics.model.ptr
        self.data: mujoco.MjData = physics.data.ptr
        parts = _visual_parts()
        ik = self.chain.model
        self._ik_body = {n: mujoco.mj_name2id(ik, mujoco.mjtObj.mjOBJ_BODY, n) for n in ("panda0_link0",) + ARM_LINKS}
        self._geoms = np.array([physics.bind(self.mjcf_model.find("geom", g)).element_id for g, _ in parts.geoms])
        self._geom_frame = [frame for _, frame in parts.geoms]
        m = self.model
        # compiled poses in the link frames (MuJoCo moves mesh geoms to the mesh's centre of volume)
        self._geom_pos0 = m.geom_pos[self._geoms].copy()
        self._geom_quat0 = m.geom_quat[self._geoms].copy()
        # kinematics must read geom_pos/geom_quat: no "same frame as the body" shortcut for these geoms
        m.geom_sameframe[self._geoms] = 0
        self._site = int(physics.bind(self.mjcf_model.find("site", GRASP_SITE)).element_id)
        self._site_pos0 = m.site_pos[self._site].copy()
        self._site_quat0 = m.site_quat[self._site].copy()
        m.site_sameframe[self._site] = 0
        self._fingers = [(name, pos, quat, self._rotate(quat, axis)) for name, pos, quat, axis in parts.fingers]
        self._bound = True
        self.set_pose(self.q, self.finger_opening)

    @staticmethod
    def _rotate(quat, vec) -> np.ndarray:
        out = np.zeros(3)
        mujoco.mju_rotVecQuat(out, np.asarray(vec, dtype=np.float64), np.asarray(quat, dtype=np.float64))
        return out

    # ---------------------------------------------------------------------------------------------------- posing
    def link_frames(self, q, finger_opening: float) -> dict[str, tuple[np.ndarray, np.ndarray]]:
        """Each link's and finger's (pos, quat) in the Panda's base frame for joint angles ``q`` (rad) and
        ``finger_opening`` (m): forward kinematics of the IK chain, fingers slid along their joint axes."""
        d = self.chain.kinematics(q)
        frames = {n: (d.xpos[b].copy(), d.xquat[b].copy()) for n, b in self._ik_body.items()}
        hand_pos, hand_quat = frames[HAND_LINK]
        for name, pos, quat, axis in self._fingers:
            p, qt = np.zeros(3), np.zeros(4)
            mujoco.mju_mulPose(p, qt, hand_pos, hand_quat, pos + finger_opening * axis, quat)
            frames[name] = (p, qt)
        return frames

    def set_pose(self, q, finger_opening: float) -> None:
        """Write joint angles ``q`` (7, rad) and ``finger_opening`` (m per finger, clipped to [0, 0.04]) into the
        model: every Panda geom's ``geom_pos``/``geom_quat`` becomes its link's frame composed with its rest pose
        in that link. Takes effect at the next ``mj_forward``/``mj_kinematics``; the physics state is untouched."""
        if not self._bound:
            raise RuntimeError("PandaHandle.bind(physics) must be called after compiling the scene")
        q = np.asarray(q, dtype=np.float64)
        if q.shape != (7,) or not np.all(np.isfinite(q)):
            raise ValueError(f"Panda joint angles must be 7 finite numbers, got {q!r}")
        opening = float(np.clip(finger_opening, 0.0, FINGER_OPEN))
        frames = self.link_frames(q, opening)
        m = self.model
        p, qt = np.zeros(3), np.zeros(4)
        for k, g in enumerate(self._geoms):
            fp, fq = frames[self._geom_frame[k]]
            mujoco.mju_mulPose(p, qt, fp, fq, self._geom_pos0[k], self._geom_quat0[k])
            m.geom_pos[g] = p
            m.geom_quat[g] = qt
        fp, fq = frames[HAND_LINK]
        mujoco.mju_mulPose(p, qt, fp, fq, self._site_pos0, self._site_quat0)
        m.site_pos[self._site] = p
        m.site_quat[self._site] = qt
        self.q = q.copy()
        self.finger_opening = opening

    def to_base(self, point) -> np.ndarray:
        """A world point in the Panda's base frame."""
        return self.chain.to_base(point)

    def hold(self, target, candidates_world, finger_opening: float) -> IKSolution:
        """Pose the arm so that the grasp point is at the world point ``target``, trying the world-frame hand
        orientations ``candidates_world`` in order (see :func:`grasp_candidates`)."""
        target = np.asarray(target, dtype=np.float64)
        if target.shape != (3,) or not np.all(np.isfinite(target)):
            raise ValueError(f"hand target must be 3 finite numbers (world x, y, z in m), got {target!r}")
        cands = [self._R.T @ r for r in candidates_world]
        ik = shared_ik()
        target_b = self.to_base(target)
        sol, i = ik.solve_grasp(target_b, cands)
        self.set_pose(sol.q, finger_opening)
        self.target = target.copy()
        # residuals against the exact request (the solver works on the target rounded to 0.1 mm)
        p, r = ik.forward(sol.q)
        pe, oe = residuals(p, r, target_b, cands[i])
        self.residual, self.orientation_residual = float(pe), float(oe)
        return sol

    def pose_for(self, env: Any, action) -> IKSolution:
        """Hold ``env.hand_target(action)``: the bob at its release angle, the object at its drop point, ...

        The hand orientation: the env's ``hand_axes(action)`` (``(approach, closing)`` world vectors) if it gives
        one; else perpendicular to the pendulum rod if the env has a pendulum tool (``env.pendulum``); else top-down.
        Fingers: closed on ``env.grip_half_width`` (default the bob's half edge) once an action is given, open before.
        """
        target = np.asarray(env.hand_target(action), dtype=np.float64)
        axes = env.hand_axes(action)
        if axes is not None:
            cands = [grasp_rotation(*axes)]
        else:
            pend = getattr(env, "pendulum", None)
            rod_top = pend.pivot() if pend is not None and hasattr(pend, "pivot") else None
            cands = grasp_candidates(target, self.shoulder, rod_top)
        if action is None:
            opening = FINGER_OPEN
        else:
            opening = float(getattr(env, "grip_half_width", DEFAULT_GRIP_HALF_WIDTH)) + FINGER_CLEARANCE
        return self.hold(target, cands, opening)

    def grasp_site_pose(self) -> tuple[np.ndarray, np.ndarray]:
        """World position and rotation matrix of the grasp point (after ``mj_forward``/``mj_kinematics``)."""
        return self.data.site_xpos[self._site].copy(), self.data.site_xmat[self._site].reshape(3, 3).copy()


def attach_panda(root: mjcf.RootElement, base_pos=(0.0, 0.0, 0.0), base_yaw: float = 0.0,
                 name: str = "panda") -> PandaHandle:
    """Attach a visual-only Panda to ``root`` with its base at world ``base_pos`` (m) turned by ``base_yaw`` (rad).

    Adds no joints, actuators or contacts (see the module docstring). Names of the attached elements are prefixed
    ``"{name}/"``. Call ``handle.bind(physics)`` after compiling ``root``.
    """
    base_pos = np.asarray(base_pos, dtype=np.float64)
    if base_pos.shape != (3,) or not np.all(np.isfinite(base_pos)) or not math.isfinite(base_yaw):
        raise ValueError(f"Panda base_pos must be 3 finite numbers and base_yaw finite, got {base_pos!r}, {base_yaw!r}")
    model = panda_mjcf()
    model.model = name
    mount = root.worldbody.add("site", name=f"{name}_mount", pos=base_pos, quat=assets.yaw_quat(base_yaw),
                               size=(0.01,), group=PANDA_SITE_GROUP)
    frame = mount.attach(model)
    return PandaHandle(model, frame, base_pos, base_yaw)
