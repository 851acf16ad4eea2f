"""Named access to a task scene's parts (dm_control's style: ``object_pos()``, not ``data.qpos[7:10]``).

A mixin of :class:`phyplan_envs.base.PhyPlanEnv`: the ids of the moving object, the goal and the cameras, looked up
once after compiling (``_init_ids``), and the accessors and setters that tasks and tools use.
"""
from __future__ import annotations

import mujoco
import numpy as np

from . import assets
from .camera import CameraModel, camera_model


class SceneAccess:
    """Named accessors of the compiled scene; needs ``model``, ``data``, ``object_name``, ``task_name``,
    ``image_size``, ``render_size`` and ``_context`` from the env."""

    def _init_ids(self) -> None:
        m = self.model
        self._obj_body = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_BODY, self.object_name)
        jnt = m.body_jntadr[self._obj_body]
        self._obj_qpos = int(m.jnt_qposadr[jnt])
        self._obj_qvel = int(m.jnt_dofadr[jnt])
        self._goal_body = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_BODY, "goal")
        self._cam_obs = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_CAMERA, "obs")
        self._cam_view = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_CAMERA, "view")
        if min(self._obj_body, self._goal_body, self._cam_obs, self._cam_view) < 0:
            raise RuntimeError(f"scene of {self.task_name!r} lacks the object, 'goal' body or 'obs'/'view' cameras")

    def camera_model(self, name: str = "obs") -> CameraModel:
        """The pinhole model (intrinsics, camera-to-world pose) of camera ``"obs"`` (at the observation's size)
        or ``"view"`` (at the ``render()`` frame's size); see :mod:`phyplan_envs.camera`."""
        sizes = {"obs": (self._cam_obs, self.image_size), "view": (self._cam_view, self.render_size)}
        if name not in sizes:
            raise ValueError(f"name must be one of {tuple(sizes)}, got {name!r}")
        cam, size = sizes[name]
        return camera_model(self.model, self.data, cam, size, size)

    def body_id(self, name: str) -> int:
        i = mujoco.mj_name2id(self.model, mujoco.mjtObj.mjOBJ_BODY, name)
        if i < 0:
            raise KeyError(f"no body named {name!r} in the {self.task_name} scene")
        return i

    def joint_qpos_adr(self, name: str) -> int:
        j = mujoco.mj_name2id(self.model, mujoco.mjtObj.mjOBJ_JOINT, name)
        if j < 0:
            raise KeyError(f"no joint named {name!r} in the {self.task_name} scene")
        return int(self.model.jnt_qposadr[j])

    def object_pos(self) -> np.ndarray:
        return self.data.qpos[self._obj_qpos:self._obj_qpos + 3].copy()

    def object_vel(self) -> np.ndarray:
        return self.data.qvel[self._obj_qvel:self._obj_qvel + 3].copy()

    def set_object_pose(self, pos, quat=(1, 0, 0, 0), vel=(0, 0, 0)) -> None:
        a = self._obj_qpos
        self.data.qpos[a:a + 3] = pos
        self.data.qpos[a + 3:a + 7] = quat
        self.data.qvel[self._obj_qvel:self._obj_qvel + 6] = 0
        self.data.qvel[self._obj_qvel:self._obj_qvel + 3] = vel

    def goal_pos(self) -> np.ndarray:
        return np.asarray(self._context["goal"], dtype=np.float64).copy()

    def set_body_pose(self, body: int, pos, yaw: float | None = None) -> None:
        """Move a static (joint-free) body in the model; takes effect at the next ``mj_forward``/``mj_step``."""
        self.model.body_pos[body] = pos
        if yaw is not None:
            self.model.body_quat[body] = assets.yaw_quat(yaw)
