"""The frames of one attempt for ``render_mode="rgb_array_list"``: set-up, release and flight at the env's fps.

:class:`AttemptFrames` collects, per episode, the ``view``-camera frames (the whole scene, the Panda included) that
``render()`` returns after ``step``:

* one frame after ``reset`` (the scene and the arm before the attempt);
* the set-up: in robot mode a frame every ``1/fps`` s of simulated set-up time while the arm executes the plan; in
  kinematic mode (``robot=None``, the tools placed instantly) :data:`KINEMATIC_SETUP_TIME` s of the visual arm
  moving in joint space from its pose before the attempt to the release pose (minimum-jerk), the scene already set;
* the flight: the physics is stepped again from the released state, in a separate ``MjData`` (the env's own
  state and outcome are untouched), for the attempt's ``n_steps``, with a frame every ``1/fps`` s and a last one
  at the end.

So an attempt has ``1 + n_setup + floor(n_steps * dt * fps) + 1`` frames (:meth:`AttemptFrames.expected_count`).
"""
from __future__ import annotations

from . import _gl  # noqa: F401  (sets MUJOCO_GL before mujoco is imported)

import math

import mujoco
import numpy as np

KINEMATIC_SETUP_TIME = 1.0     # s of arm motion shown before a kinematic-mode release
STATE_SPEC = mujoco.mjtState.mjSTATE_INTEGRATION


def _min_jerk(s: float) -> float:
    s = min(1.0, max(0.0, s))
    return s * s * s * (10.0 - 15.0 * s + 6.0 * s * s)


class AttemptFrames:
    """Frames of the current episode, drawn by ``view`` (a :class:`phyplan_envs.rendering.CameraView`)."""

    def __init__(self, view, fps: float):
        if not (isinstance(fps, (int, float)) and fps > 0):
            raise ValueError(f"render_fps must be a positive number, got {fps!r}")
        self.view = view
        self.fps = float(fps)
        self.frames: list[np.ndarray] = []
        self.n_setup = 0
        self._next = 0.0

    # ----------------------------------------------------------------------------------------------- episode
    def reset(self, data) -> None:
        """A new episode: the frames are cleared and the scene as reset is drawn."""
        self.frames = [self.view.draw(data)]
        self.n_setup = 0
        self._next = 1.0 / self.fps

    def setup_tick(self, data, clock: float) -> None:
        """Robot mode: called as the set-up advances (``clock``: simulated seconds since the attempt began)."""
        while clock + 1e-9 >= self._next:
            self.frames.append(self.view.draw(data))
            self.n_setup += 1
            self._next += 1.0 / self.fps

    def kinematic_setup(self, model, data, panda, q_from, q_to, opening: float) -> None:
        """Kinematic mode: the visual arm moves from ``q_from`` to ``q_to`` (fingers at ``opening``)."""
        n = int(round(KINEMATIC_SETUP_TIME * self.fps))
        q_from, q_to = np.asarray(q_from), np.asarray(q_to)
        for k in range(1, n + 1):
            s = _min_jerk(k / n)
            panda.set_pose((1.0 - s) * q_from + s * q_to, opening)
            mujoco.mj_kinematics(model, data)
            self.frames.append(self.view.draw(data))
        self.n_setup = n

    def flight(self, model, release_state: np.ndarray, n_steps: int) -> None:
        """Replay the flight from ``release_state`` (``mj_getState``, :data:`STATE_SPEC`) in a separate MjData."""
        d = mujoco.MjData(model)
        mujoco.mj_setState(model, d, release_state, STATE_SPEC)
        mujoco.mj_forward(model, d)
        step_and_draw(model, d, n_steps, self.fps, lambda: self.frames.append(self.view.draw(d)))

    @staticmethod
    def release_state(model, data) -> np.ndarray:
        state = np.empty(mujoco.mj_stateSize(model, STATE_SPEC))
        mujoco.mj_getState(model, data, state, STATE_SPEC)
        return state

    def expected_count(self, n_steps: int, dt: float) -> int:
        """Frames of an attempt with ``n_setup`` set-up frames that ran ``n_steps`` flight steps of ``dt``."""
        return 1 + self.n_setup + int(math.floor(n_steps * dt * self.fps + 1e-9)) + 1


def step_and_draw(model, data, n_steps: int, fps: float, draw) -> None:
    """Step ``data`` ``n_steps`` times, calling ``draw()`` every ``1/fps`` simulated seconds and once at the end (the
    flight's frame times, shared by the kinematic replay and robot mode's arm-free one)."""
    dt = model.opt.timestep
    period = 1.0 / fps
    nxt = period
    for i in range(1, int(n_steps) + 1):
        mujoco.mj_step(model, data)
        if i * dt + 1e-9 >= nxt:
            draw()
            nxt += period
    draw()
