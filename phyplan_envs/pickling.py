"""Pickle and deepcopy of the envs: rebuilt from their constructor arguments, then their context restored.

A mixin of :class:`phyplan_envs.base.PhyPlanEnv`. MuJoCo models, renderers and the MJCF tree do not pickle (and
should not travel: a copy compiles its own scene), so :meth:`Rebuildable.__reduce__` sends the constructor
arguments and the episode state, and :func:`rebuild_env` makes a fresh env and resets it to the same context with
the same random generator, so the copy gives the same outcomes (``AsyncVectorEnv`` cloudpickles env factories;
Gymnasium's own tests pickle envs).
"""
from __future__ import annotations

from typing import Any, Mapping

import numpy as np


class Rebuildable:
    """Records the constructor arguments at ``__new__`` and pickles as (class, arguments, episode state)."""

    def __new__(cls, *args: Any, **kwargs: Any):
        env = super().__new__(cls)
        env._init_args = (args, dict(kwargs))     # the constructor arguments, for pickle and deepcopy
        return env

    def __reduce__(self):
        """Pickle and deepcopy rebuild the env from its constructor arguments and restore its context, random
        generator and spec, so that the copy gives the same outcomes (an env that has stepped is back at the
        start of its context, and still needs ``reset()`` before the next ``step``)."""
        args, kwargs = self._init_args
        state = {"context": self._context, "np_random": self._np_random, "np_random_seed": self._np_random_seed,
                 "needs_reset": self._needs_reset, "last_action": self._last_action,
                 "record_trajectory": self._episode_record, "spec": self.spec}
        return rebuild_env, (type(self), args, kwargs, state)


def rebuild_env(cls: type, args: tuple, kwargs: dict, state: Mapping[str, Any]) -> Any:
    """The inverse of :meth:`Rebuildable.__reduce__`."""
    env = cls(*args, **kwargs)
    env.spec = state["spec"]
    if state["context"] is not None:
        env.reset(options={"context": state["context"], "record_trajectory": state["record_trajectory"]})
        env._needs_reset = state["needs_reset"]
        env._last_action = None if state["last_action"] is None else np.array(state["last_action"])
    env._np_random, env._np_random_seed = state["np_random"], state["np_random_seed"]
    return env
