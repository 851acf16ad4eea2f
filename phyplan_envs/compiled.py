"""Compiled scenes, built once per process: every env gets its own copy of a cached compiled model.

Compiling a task scene with the Panda takes most of ``gym.make`` and its model holds ~23 MiB of buffers
(``env.model.nbuffer``; the Panda's visual meshes have ~69k vertices), and every env of a task compiles the same
MJCF. :func:`compile_scene` keys the compiled model by the scene's XML (asset file names in it carry a hash of
their content, so equal XML means an equal model), keeps the last :data:`MAX_SCENES` of them, and hands each env a
copy (``mj_copyModel``: the same buffers, bit for bit, as a fresh compile) in an ``mjcf.Physics`` that binds to the
env's MJCF tree exactly as ``Physics.from_mjcf_model`` would.

:func:`release` is what an env's ``close()`` calls: it frees the physics' MuJoCo data now (dm_control's objects
reference each other, so without it only Python's cyclic garbage collector would free them, long after the env
is gone) and, on glibc, hands the freed heap pages back to the operating system (``malloc_trim``): MuJoCo's large
model buffers otherwise stay in the process as free-but-mapped memory and the RSS of a make/close loop climbs
(``tests/test_env_inputs.py`` bounds the RSS growth of make/close cycles in a fresh process).
"""
from __future__ import annotations

from . import _gl  # noqa: F401  (sets MUJOCO_GL before mujoco is imported)

import copy
import ctypes
import ctypes.util
import threading
from collections import OrderedDict

import mujoco
from dm_control import mjcf
from dm_control.mujoco import wrapper

MAX_SCENES = 4
"""Compiled scenes kept per process (least recently used dropped first); ~23 MB each with the Panda."""

_SCENES: "OrderedDict[str, mujoco.MjModel]" = OrderedDict()
_LOCK = threading.Lock()


def compile_scene(root: mjcf.RootElement) -> mjcf.Physics:
    """An ``mjcf.Physics`` of ``root`` (as ``mjcf.Physics.from_mjcf_model(root)``) on a fresh copy of the cached
    compiled model of its XML; the first env of a scene compiles it."""
    xml = root.to_xml_string()
    with _LOCK:
        template = _SCENES.get(xml)
        if template is not None:
            _SCENES.move_to_end(xml)
    if template is None:
        template = wrapper.MjModel.from_xml_string(xml, assets=root.get_assets()).ptr
        with _LOCK:
            _SCENES[xml] = template
            while len(_SCENES) > MAX_SCENES:
                _SCENES.popitem(last=False)
    return mjcf.Physics.from_model(wrapper.MjModel(copy.copy(template)))


def cached_scenes() -> int:
    """How many compiled scenes the cache holds."""
    return len(_SCENES)


def clear_cache() -> None:
    """Drop the cached compiled scenes (envs made before keep their own copies)."""
    with _LOCK:
        _SCENES.clear()


def _libc_trim():
    name = ctypes.util.find_library("c")
    try:
        libc = ctypes.CDLL(name) if name else None
        return libc.malloc_trim if libc is not None and hasattr(libc, "malloc_trim") else None
    except OSError:
        return None


_MALLOC_TRIM = _libc_trim()


def release(physics: mjcf.Physics | None) -> None:
    """Free ``physics``' MuJoCo data now and return freed heap memory to the OS (glibc only; elsewhere a no-op)."""
    if physics is not None:
        physics.free()
    trim_heap()


def trim_heap() -> None:
    """``malloc_trim(0)`` on glibc: give the free pages of the C heap back to the operating system."""
    if _MALLOC_TRIM is not None:
        _MALLOC_TRIM(0)
