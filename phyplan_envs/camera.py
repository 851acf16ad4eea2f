"""Perception inputs: the pinhole model of an env camera and the depth picture of the observation camera.

``obs_mode="rgbd"`` gives a Dict observation ``{"rgb": uint8 H x W x 3, "depth": float32 H x W}`` from the fixed
``obs`` camera (the Panda hidden, as in the image mode: its ``rgb`` is the ``"image"`` observation bit for bit).
``depth`` is the z-depth in metres: the distance of the surface seen at a pixel from the camera's image plane,
along the optical axis (not the length of the ray).

:meth:`PhyPlanEnv.camera_model(name) <phyplan_envs.base.PhyPlanEnv.camera_model>` returns a :class:`CameraModel`:
intrinsics ``fx, fy, cx, cy`` (pixels) and the camera-to-world pose, in the OpenCV convention (camera x right,
y down, z forward along the optical axis). Pixel ``(row i, column j)`` covers ``u in [j, j + 1)``,
``v in [i, i + 1)``; its centre is ``(j + 0.5, i + 0.5)``. So a depth picture back-projects to world points::

    cam = env.unwrapped.camera_model("obs")
    obs, _ = env.reset(seed=0)
    points = cam.depth_to_world(obs["depth"])      # H x W x 3 world points (m)

The calibration is a fixed, public property of the env (like a calibrated camera's): it does not depend on the
context, and an agent may read it from its own copy of the env.
"""
from __future__ import annotations

from dataclasses import dataclass, replace

import mujoco
import numpy as np

from .rendering import CameraView, new_renderer

# MuJoCo's camera frame (x right, y up, looking along -z) -> OpenCV's (x right, y down, z forward)
_GL_TO_CV = np.diag([1.0, -1.0, -1.0])


@dataclass(frozen=True)
class CameraModel:
    """A pinhole camera: intrinsics (pixels) and camera-to-world pose (OpenCV axes).

    Attributes:
        name: the camera's name in the scene.
        width, height: the picture size (pixels).
        fovy: the vertical field of view (degrees), from which ``fx = fy = (height / 2) / tan(fovy / 2)``.
        cx, cy: the principal point (``width / 2``, ``height / 2``).
        position: the camera centre in world coordinates (m), shape (3,).
        rotation: camera-to-world rotation (3, 3); its columns are the camera's x (right), y (down) and z
            (forward) axes in world coordinates.
    """

    name: str
    width: int
    height: int
    fovy: float
    position: np.ndarray
    rotation: np.ndarray

    @property
    def fy(self) -> float:
        return (self.height / 2.0) / np.tan(np.radians(self.fovy) / 2.0)

    @property
    def fx(self) -> float:
        return self.fy   # square pixels: MuJoCo keeps the aspect ratio of the picture

    @property
    def cx(self) -> float:
        return self.width / 2.0

    @property
    def cy(self) -> float:
        return self.height / 2.0

    @property
    def intrinsics(self) -> np.ndarray:
        """The 3 x 3 matrix ``K = [[fx, 0, cx], [0, fy, cy], [0, 0, 1]]``."""
        return np.array([[self.fx, 0.0, self.cx], [0.0, self.fy, self.cy], [0.0, 0.0, 1.0]])

    @property
    def pose(self) -> np.ndarray:
        """The 4 x 4 camera-to-world transform (world point = R @ camera point + position)."""
        t = np.eye(4)
        t[:3, :3] = self.rotation
        t[:3, 3] = self.position
        return t

    def resized(self, height: int, width: int) -> "CameraModel":
        """The same camera drawing pictures of ``height`` x ``width`` pixels (same fovy and pose)."""
        if int(height) < 1 or int(width) < 1:
            raise ValueError(f"height and width must be positive, got {height!r} x {width!r}")
        return replace(self, height=int(height), width=int(width))

    def back_project(self, u, v, depth) -> np.ndarray:
        """World points (..., 3) of pixel coordinates ``u`` (along a row), ``v`` (down) at z-depth ``depth`` (m)."""
        u, v, z = np.broadcast_arrays(np.asarray(u, dtype=np.float64), np.asarray(v, dtype=np.float64),
                                      np.asarray(depth, dtype=np.float64))
        cam = np.stack([(u - self.cx) / self.fx * z, (v - self.cy) / self.fy * z, z], axis=-1)
        return cam @ self.rotation.T + self.position

    def project(self, points) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Pixel coordinates ``(u, v)`` and z-depth of world points (..., 3)."""
        cam = (np.asarray(points, dtype=np.float64) - self.position) @ self.rotation
        z = cam[..., 2]
        return self.cx + self.fx * cam[..., 0] / z, self.cy + self.fy * cam[..., 1] / z, z

    def pixel_centres(self) -> tuple[np.ndarray, np.ndarray]:
        """``(u, v)`` of every pixel centre, each of shape (height, width)."""
        v, u = np.mgrid[0:self.height, 0:self.width].astype(np.float64) + 0.5
        return u, v

    def depth_to_world(self, depth) -> np.ndarray:
        """The world point (m) seen at every pixel of a depth picture (height x width): shape (height, width, 3)."""
        depth = np.asarray(depth)
        if depth.shape != (self.height, self.width):
            raise ValueError(f"depth must have shape ({self.height}, {self.width}) for camera {self.name!r}, "
                             f"got {depth.shape}")
        u, v = self.pixel_centres()
        return self.back_project(u, v, depth)


def camera_model(model: mujoco.MjModel, data: mujoco.MjData, camera: int, height: int, width: int) -> CameraModel:
    """The :class:`CameraModel` of camera id ``camera`` drawing ``height`` x ``width`` pictures.

    A camera fixed in the world body is read from the model; one on a moving body from ``data`` (its kinematics
    must be current, i.e. after ``mj_forward``)."""
    if not 0 <= camera < model.ncam:
        raise ValueError(f"camera must be a camera id in [0, {model.ncam}), got {camera!r}")
    if model.cam_bodyid[camera] == 0:
        pos = np.array(model.cam_pos[camera], dtype=np.float64)
        mat = np.zeros(9)
        mujoco.mju_quat2Mat(mat, np.array(model.cam_quat[camera], dtype=np.float64))
        gl = mat.reshape(3, 3)
    else:
        pos = np.array(data.cam_xpos[camera], dtype=np.float64)
        gl = np.array(data.cam_xmat[camera], dtype=np.float64).reshape(3, 3)
    name = mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_CAMERA, camera) or str(camera)
    return CameraModel(name, int(width), int(height), float(model.cam_fovy[camera]), pos, gl @ _GL_TO_CV)


class DepthView(CameraView):
    """A :class:`~phyplan_envs.rendering.CameraView` that draws z-depth (float32 metres, height x width)."""

    def draw(self, data: mujoco.MjData) -> np.ndarray:
        if self._renderer is None:
            self._renderer = new_renderer(self.model, self.height, self.width)
            self._renderer.enable_depth_rendering()
            self._option = mujoco.MjvOption()
            for g, shown in self.geomgroups.items():
                self._option.geomgroup[g] = int(shown)
        self._renderer.update_scene(data, camera=self.camera, scene_option=self._option)
        return self._renderer.render().astype(np.float32, copy=True)
