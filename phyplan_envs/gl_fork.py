"""Rendering and ``fork``: a forked child of a process that has rendered with EGL cannot render.

The EGL driver's state (with Mesa's llvmpipe: its rasteriser threads) does not survive ``fork``: a forked child
of a process that has opened a renderer waits forever in its first ``render``. ``AsyncVectorEnv`` and
``multiprocessing`` pools fork by default on Linux (Python < 3.14), so ``gym.make_vec(..., vectorization_mode=
"async", obs_mode="image")`` after any ``render()`` in the parent used to hang.

:func:`before_renderer` runs before every renderer is made (``phyplan_envs.rendering.new_renderer``):

* at the first renderer of a process whose default ``multiprocessing`` start method is ``"fork"`` (fixed or not
  yet fixed: it is often fixed implicitly, e.g. by tqdm's multiprocessing lock), it switches the default to
  ``"forkserver"`` (children start from a clean server process that never rendered) and says so with a
  ``RuntimeWarning``; code that picks its own context (``mp.get_context("spawn")``,
  ``AsyncVectorEnv(..., context="spawn")``, even ``mp.get_context("fork")``) is unaffected;
* in a child forked from a process that had rendered, it raises ``RuntimeError`` (instead of hanging) naming the
  fix: a ``spawn`` or ``forkserver`` context.
"""
from __future__ import annotations

import multiprocessing as mp
import os
import warnings

_OPENED = False        # this process has made a renderer
_INHERITED = False     # this process was forked from one that had


def before_renderer() -> None:
    """Check that this process can render, and keep later ``multiprocessing`` children from forking its GL state."""
    global _OPENED
    if _INHERITED:
        raise RuntimeError(
            "phyplan_envs: this process was forked from one that had already rendered with EGL, and EGL does not "
            "survive fork (the render would hang). Start worker processes with 'spawn' or 'forkserver' instead, "
            "e.g. gym.make_vec(..., vectorization_mode='async', vector_kwargs={'context': 'forkserver'}) or "
            "multiprocessing.set_start_method('forkserver') before the first render.")
    if _OPENED:
        return
    _OPENED = True
    method = mp.get_start_method(allow_none=True)
    if method in (None, "fork") and "forkserver" in mp.get_all_start_methods() \
            and mp.get_all_start_methods()[0] == "fork":
        # force: the default is often fixed to 'fork' implicitly (e.g. by tqdm's multiprocessing lock)
        mp.set_start_method("forkserver", force=True)
        warnings.warn(
            "phyplan_envs: this process now renders with EGL, which forked children cannot use; the default "
            "multiprocessing start method is switched from 'fork' to 'forkserver' (async vector envs and pools "
            "started with the default context use it; explicit contexts such as mp.get_context('fork') are not "
            "changed).", RuntimeWarning, stacklevel=3)


def _after_fork_in_child() -> None:
    global _INHERITED
    if _OPENED:
        _INHERITED = True


if hasattr(os, "register_at_fork"):
    os.register_at_fork(after_in_child=_after_fork_in_child)
