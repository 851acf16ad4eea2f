"""Envs rebuilt from their constructor arguments: pickle and deepcopy, and robot mode's kinematic twin.

MuJoCo models, renderers and the MJCF tree do not pickle (and should not travel: a copy compiles its own scene), so
:meth:`phyplan_envs.base.PhyPlanEnv.__reduce__` (:func:`reduce_env`) sends the constructor arguments recorded at
``__new__`` and the episode state, and :func:`rebuild_env` makes a fresh env and resets it to the same context with
the same random generator, so the copy gives the same outcomes (``AsyncVectorEnv`` cloudpickles env factories;
Gymnasium's own tests pickle envs). :func:`kinematic_twin` makes the same env in the kinematic mode, without the
visual Panda (robot mode's arm-free flight: :mod:`phyplan_envs.panda.robot.flight`).
"""
from __future__ import annotations

import inspect
from typing import Any, Mapping

import numpy as np


def reduce_env(env) -> tuple:
    """``env.__reduce__()``: rebuild from the constructor arguments and restore the context, random generator and
    spec (an env that has stepped is back at the start of its context, and still needs ``reset()`` before the next
    ``step``)."""
    args, kwargs = env._init_args
    state = {"context": env._context, "np_random": env._np_random, "np_random_seed": env._np_random_seed,
             "needs_reset": env._needs_reset, "last_action": env._last_action,
             "record_trajectory": env._episode_record, "spec": env.spec}
    return rebuild_env, (type(env), args, kwargs, state)


def rebuild_env(cls: type, args: tuple, kwargs: dict, state: Mapping[str, Any]) -> Any:
    """The inverse of :func:`reduce_env`."""
    env = cls(*args, **kwargs)
    env.spec = state["spec"]
    if state["context"] is not None:
        env.reset(options={"context": state["context"], "record_trajectory": state["record_trajectory"]})
        env._needs_reset = state["needs_reset"]
        env._last_action = None if state["last_action"] is None else np.array(state["last_action"])
    env._np_random, env._np_random_seed = state["np_random"], state["np_random_seed"]
    return env


def kinematic_twin(env, base_init) -> Any:
    """``env``'s class made with its constructor arguments (positional ones named by ``base_init``'s signature) in
    the kinematic mode, without the visual Panda (which changes no outcome), rendering nothing, state observations."""
    args, kwargs = env._init_args
    names = list(inspect.signature(base_init).parameters)[1:]     # positional arguments by name
    kw = dict(zip(names, args))
    kw.update(kwargs)
    kw.update(robot=None, with_panda=False, render_mode=None, obs_mode="state", record_trajectory=False)
    return type(env)(**kw)
