"""Offscreen rendering for the phyplan envs: renderer lifetime and the fixed-camera views an env draws.

Like Gymnasium's ``mujoco_rendering.py``, this keeps the GL side out of the env logic. An env owns one
:class:`CameraView` per picture it makes (the image observation from the ``obs`` camera, the ``render()`` frame from
the ``view`` camera); a view opens its ``mujoco.Renderer`` at the first draw, so state-only envs never touch GL, and
:meth:`CameraView.close` frees it (a later draw opens a new one).

Renderers still open at interpreter exit must be closed before MuJoCo's EGL display is torn down, or EGL prints
errors: every renderer made by :func:`new_renderer` is tracked in a weak set, and an ``atexit`` hook closes the live
ones. The hook is registered when the first renderer exists, i.e. after mujoco's own (atexit runs LIFO).
"""
from __future__ import annotations

from . import _gl  # noqa: F401  (sets MUJOCO_GL before mujoco is imported)

import atexit
import weakref
from typing import Mapping

import mujoco
import numpy as np

from . import gl_fork

_LIVE_RENDERERS: "weakref.WeakSet[mujoco.Renderer]" = weakref.WeakSet()
_EXIT_HOOK = False


def new_renderer(model: mujoco.MjModel, height: int, width: int) -> mujoco.Renderer:
    """A ``mujoco.Renderer`` that is closed at interpreter exit if its owner has not closed it."""
    global _EXIT_HOOK
    gl_fork.before_renderer()        # raises in a forked child of a rendering process; avoids fork afterwards
    r = mujoco.Renderer(model, height, width)
    _LIVE_RENDERERS.add(r)
    if not _EXIT_HOOK:
        atexit.register(close_renderers)
        _EXIT_HOOK = True
    return r


def close_renderers() -> None:
    """Close every renderer made by :func:`new_renderer` that is still alive (best effort; the atexit hook)."""
    for r in list(_LIVE_RENDERERS):
        try:
            r.close()
        except Exception:  # noqa: BLE001 - best effort at exit
            pass


def live_renderers() -> int:
    """How many renderers made by :func:`new_renderer` are still alive (open or not yet garbage-collected)."""
    return len(_LIVE_RENDERERS)


class CameraView:
    """One fixed camera of ``model`` drawn at ``height`` x ``width`` with some geom groups shown or hidden.

    Args:
        model: the compiled model (the view keeps a reference; the renderer uploads it at the first draw).
        camera: the camera id.
        height, width: the picture size in pixels.
        geomgroups: ``{group: shown}`` overrides of MuJoCo's default geom-group visibility (groups 0-2 shown,
            3-5 hidden), e.g. ``{4: True}`` to draw the Panda.
    """

    def __init__(self, model: mujoco.MjModel, camera: int, height: int, width: int,
                 geomgroups: Mapping[int, bool] | None = None):
        if camera < 0 or camera >= model.ncam:
            raise ValueError(f"camera must be a camera id in [0, {model.ncam}), got {camera!r}")
        self.model = model
        self.camera = int(camera)
        self.height = int(height)
        self.width = int(width)
        self.geomgroups = dict(geomgroups or {})
        for g in self.geomgroups:
            if not 0 <= g < mujoco.mjNGROUP:
                raise ValueError(f"geomgroups keys must be geom groups in [0, {mujoco.mjNGROUP}), got {g!r}")
        self._renderer: mujoco.Renderer | None = None
        self._option: mujoco.MjvOption | None = None

    @property
    def is_open(self) -> bool:
        """Whether a renderer is open (between the first draw and :meth:`close`)."""
        return self._renderer is not None

    def draw(self, data: mujoco.MjData) -> np.ndarray:
        """The camera's picture of ``data`` (uint8, height x width x 3, a fresh array). Uses the kinematics in
        ``data`` as they are: call ``mj_forward`` (or ``mj_kinematics``) after changing the state or the model."""
        if self._renderer is None:
            self._renderer = new_renderer(self.model, self.height, self.width)
            self._option = mujoco.MjvOption()
            for g, shown in self.geomgroups.items():
                self._option.geomgroup[g] = int(shown)
        self._renderer.update_scene(data, camera=self.camera, scene_option=self._option)
        return self._renderer.render().copy()

    def close(self) -> None:
        """Free the renderer (idempotent); a later :meth:`draw` opens a new one."""
        if self._renderer is not None:
            self._renderer.close()
            self._renderer = None
