"""A task's compiled scene with named access (dm_control's style: ``scene.object_pos()``, not ``data.qpos[7:10]``).

:class:`Scene` holds the compiled physics of one env (``physics``, ``model``, ``data``) and the ids of the parts
every task has (the moving object, the goal, the ``obs`` and ``view`` cameras), looked up once after compiling;
tools (:mod:`phyplan_envs.tools`) look up their own parts through it. The env exposes the same accessors
(:meth:`phyplan_envs.base.PhyPlanEnv.object_pos`, ...), which delegate here.
"""
from __future__ import annotations

from typing import NamedTuple

import mujoco
import numpy as np

from . import assets
from .camera import CameraModel, camera_model

_KIND = {"body": mujoco.mjtObj.mjOBJ_BODY, "geom": mujoco.mjtObj.mjOBJ_GEOM, "joint": mujoco.mjtObj.mjOBJ_JOINT,
         "camera": mujoco.mjtObj.mjOBJ_CAMERA, "site": mujoco.mjtObj.mjOBJ_SITE}


class ObjectState(NamedTuple):
    """The moving object's state: position (m), orientation quaternion (w, x, y, z), velocity (m/s), angular
    velocity (rad/s), world frame."""

    pos: np.ndarray
    quat: np.ndarray
    vel: np.ndarray
    angvel: np.ndarray


class Scene:
    """Named access to a compiled task scene (``physics`` an ``mjcf.Physics``); ``label`` names it in errors."""

    def __init__(self, physics, object_name: str, label: str):
        self.physics = physics
        self.model: mujoco.MjModel = physics.model.ptr
        self.data: mujoco.MjData = physics.data.ptr
        self.label = label
        m = self.model
        self.object_body = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_BODY, object_name)
        self.goal_body = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_BODY, "goal")
        self.obs_camera = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_CAMERA, "obs")
        self.view_camera = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_CAMERA, "view")
        if min(self.object_body, self.goal_body, self.obs_camera, self.view_camera) < 0:
            raise RuntimeError(f"scene of {label!r} lacks the object, 'goal' body or 'obs'/'view' cameras")
        jnt = m.body_jntadr[self.object_body]
        self.object_qpos = int(m.jnt_qposadr[jnt])      # the object's free joint: position, then quaternion
        self.object_qvel = int(m.jnt_dofadr[jnt])       # linear, then angular velocity

    # ---------------------------------------------------------------------------------------------------- names
    def id(self, kind: str, name: str) -> int:
        """The id of the ``kind`` (``"body"``, ``"geom"``, ``"joint"``, ``"camera"``, ``"site"``) named ``name``;
        ``KeyError`` naming the scene if there is none."""
        i = mujoco.mj_name2id(self.model, _KIND[kind], name)
        if i < 0:
            raise KeyError(f"no {kind} named {name!r} in the {self.label} scene")
        return i

    def body_id(self, name: str) -> int:
        return self.id("body", name)

    def geom_id(self, name: str) -> int:
        return self.id("geom", name)

    def joint_qpos_adr(self, name: str) -> int:
        return int(self.model.jnt_qposadr[self.id("joint", name)])

    def joint_dof_adr(self, name: str) -> int:
        return int(self.model.jnt_dofadr[self.id("joint", name)])

    # --------------------------------------------------------------------------------------------------- object
    def object_pos(self) -> np.ndarray:
        return self.data.qpos[self.object_qpos:self.object_qpos + 3].copy()

    def object_vel(self) -> np.ndarray:
        return self.data.qvel[self.object_qvel:self.object_qvel + 3].copy()

    def object_state(self) -> ObjectState:
        """The moving object's state now (copies)."""
        q, v, d = self.object_qpos, self.object_qvel, self.data
        return ObjectState(d.qpos[q:q + 3].copy(), d.qpos[q + 3:q + 7].copy(), d.qvel[v:v + 3].copy(),
                           d.qvel[v + 3:v + 6].copy())

    def set_object_pose(self, pos, quat=(1, 0, 0, 0), vel=(0, 0, 0)) -> None:
        a = self.object_qpos
        self.data.qpos[a:a + 3] = pos
        self.data.qpos[a + 3:a + 7] = quat
        self.data.qvel[self.object_qvel:self.object_qvel + 6] = 0
        self.data.qvel[self.object_qvel:self.object_qvel + 3] = vel

    def set_body_pose(self, body: int, pos, yaw: float | None = None) -> None:
        """Move a static (joint-free) body in the model; takes effect at the next ``mj_forward``/``mj_step``."""
        self.model.body_pos[body] = pos
        if yaw is not None:
            self.model.body_quat[body] = assets.yaw_quat(yaw)

    def place_goal(self, goal) -> None:
        """The goal box at ``goal`` (x, y), at its built height."""
        z = self.model.body_pos[self.goal_body][2]
        self.set_body_pose(self.goal_body, (goal[0], goal[1], z))

    # ------------------------------------------------------------------------------------------------ contacts
    def contact_pairs(self) -> list[tuple[str, str]]:
        """The geom names of every active contact (after ``mj_forward`` or a step), in MuJoCo's order."""
        m, d = self.model, self.data
        name = lambda g: mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_GEOM, g) or str(g)  # noqa: E731
        return [(name(int(c.geom1)), name(int(c.geom2))) for c in d.contact[:d.ncon]]

    def touching(self, geom1: int, geom2: int) -> bool:
        """Whether geoms ``geom1`` and ``geom2`` (ids) are in contact now."""
        d = self.data
        return any({int(c.geom1), int(c.geom2)} == {geom1, geom2} for c in d.contact[:d.ncon])

    # ------------------------------------------------------------------------------------------------- cameras
    def camera_model(self, camera: int, size: int) -> CameraModel:
        return camera_model(self.model, self.data, camera, size, size)
