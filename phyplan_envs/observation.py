"""What an env shows: the observation in its ``obs_mode``, the ``render()`` frame, an attempt's video frames and
the cameras' pinhole models. :class:`Observer` owns the views (:mod:`phyplan_envs.rendering`,
:mod:`phyplan_envs.camera`): the observation camera shows the task (goal, object, tools) and hides the Panda's geom
group; ``render()`` frames show it. With the env's ``camera_noise`` option, :attr:`Observer.noise` (the context's
:class:`~phyplan_envs.camera_noise.NoiseRealisation`, set at each reset) makes the observation camera's pictures
those of an imperfect camera (:mod:`phyplan_envs.camera_noise`)."""
from __future__ import annotations

from typing import Callable

import mujoco
import numpy as np

from .camera import CameraModel, DepthView
from .rendering import CameraView

# The Panda's geom group (phyplan_envs.panda.PANDA_GEOM_GROUP; Bounce's Panda stand uses it too): drawn by render(),
# hidden from the observation camera.
ROBOT_GEOM_GROUP = 4


class Observer:
    """The views of ``env`` (its ``scene``, ``obs_mode``, ``image_size``, ``render_size`` and ``render_mode``)."""

    def __init__(self, env):
        scene, size = env.scene, env.image_size
        self.scene, self.obs_mode, self.image_size, self.render_size = scene, env.obs_mode, size, env.render_size
        self.obs_view = CameraView(scene.model, scene.obs_camera, size, size, {ROBOT_GEOM_GROUP: False})
        self.frame_view = CameraView(scene.model, scene.view_camera, env.render_size, env.render_size,
                                     {ROBOT_GEOM_GROUP: True})
        self.depth_view = DepthView(scene.model, scene.obs_camera, size, size,
                                    {ROBOT_GEOM_GROUP: False})   # rgbd mode only (opens at its first draw)
        self.noise = None       # camera_noise: this context's NoiseRealisation (set by the env's reset)
        self.frames = None      # rgb_array_list: the frames of the current attempt (phyplan_envs.video)
        if env.render_mode == "rgb_array_list":
            from .video import AttemptFrames

            self.frames = AttemptFrames(self.frame_view, env.metadata["render_fps"])

    def observe(self, goal, object_pos, task_state: Callable[[], list]):
        """The observation in ``obs_mode``: the state vector ``goal_x, goal_y, object_x, object_y, object_z`` and
        ``task_state()`` (float32), the observation camera's picture, or both."""
        def state() -> np.ndarray:
            g, p = goal, object_pos
            return np.array([g[0], g[1], p[0], p[1], p[2], *task_state()], dtype=np.float32)

        if self.obs_mode == "state":
            return state()
        if self.obs_mode == "image":
            return self.pictures(depth=False)[0]
        if self.obs_mode == "rgbd":
            rgb, depth = self.pictures(depth=True)
            return {"rgb": rgb, "depth": depth}
        return {"state": state(), "image": self.pictures(depth=False)[0]}

    def pictures(self, depth: bool) -> tuple[np.ndarray, np.ndarray | None]:
        """The observation camera's picture and (``depth``) its depth picture, through :attr:`noise` if set."""
        data, noise = self.scene.data, self.noise
        if noise is None:
            return self.obs_view.draw(data), (self.depth_view.draw(data) if depth else None)
        with noise.posed(data, self.scene.obs_camera):
            rgb = self.obs_view.draw(data)
            z = self.depth_view.draw(data) if depth else None
        return noise.colour(rgb), (None if z is None else noise.depth(z))

    def start_video(self, executor) -> None:
        """rgb_array_list: a new episode's frames, the first of the scene as reset (the arm posed as ``render()``
        shows it before an attempt)."""
        if self.frames is not None:
            if executor.pose_arm(None):
                mujoco.mj_kinematics(self.scene.model, self.scene.data)
            self.frames.reset(self.scene.data)

    def end_video(self, executor, n_steps: int) -> None:
        """rgb_array_list: the flight's frames (``n_steps`` physics steps), drawn by ``executor``."""
        if self.frames is not None:
            executor.draw_flight(self.frames, n_steps)

    def frame(self) -> np.ndarray:
        """The ``render()`` frame of the scene as it is (its kinematics current)."""
        return self.frame_view.draw(self.scene.data)

    def camera_model(self, name: str) -> CameraModel:
        """The pinhole model of camera ``"obs"`` (at the observation's size) or ``"view"`` (the frame's)."""
        sizes = {"obs": (self.scene.obs_camera, self.image_size), "view": (self.scene.view_camera, self.render_size)}
        if name not in sizes:
            raise ValueError(f"name must be one of {tuple(sizes)}, got {name!r}")
        return self.scene.camera_model(*sizes[name])

    def true_camera_model(self) -> CameraModel:
        """The ``obs`` camera at the pose it draws from in this context (:attr:`noise`'s; else the nominal one)."""
        nominal = self.camera_model("obs")
        return nominal if self.noise is None else self.noise.true_camera(nominal)

    def close(self) -> None:
        for view in (self.obs_view, self.frame_view, self.depth_view):
            view.close()
