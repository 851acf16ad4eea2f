"""An episode's context at reset: the reset's inputs checked, the context restored or sampled, its goal checked.

:meth:`phyplan_envs.base.PhyPlanEnv.reset` calls, in this order:

* :func:`reset_inputs` before the env's random generator is reseeded: ``seed`` and ``options`` checked against
  ``env.reset_options`` (a varied task's hidden physics takes its own options first), a given
  ``options["context"]`` checked against ``env.context_keys`` (the camera noise's and the hidden physics' entries by
  their own checks), ``options["goal"]`` and ``options["record_trajectory"]`` (default ``env.record_trajectory``);
* :func:`episode_context` after it: the given context, or one drawn by ``env.sample_context(env.np_random)``, with
  ``options["goal"]`` in place of its goal if given; the goal (float64) must lie in ``env.goal_region``;
* :func:`check_start_distance` once the scene is at its start: the object's start must be at least
  ``env.min_goal_distance`` from the goal in xy (the reward ``1 - d/d0`` divides by that distance).

Each bad input raises ``TypeError``/``ValueError`` naming it (the checks are :mod:`phyplan_envs.spaces`').
"""
from __future__ import annotations

from typing import Any, Mapping, NamedTuple

import numpy as np

from . import camera_noise as cn
from .spaces import check_context, check_flag, check_goal, check_goal_region, check_reset_options, check_seed
from .spaces import format_xy as _xy


class ResetInputs(NamedTuple):
    """What a reset was given, checked: the seed, ``options["context"]`` and ``options["goal"]`` (``None`` when not
    given) and whether to record the trajectory."""

    seed: int | None
    context: dict[str, Any] | None
    goal: np.ndarray | None
    record: bool


def reset_inputs(env, seed, options: Mapping[str, Any] | None) -> ResetInputs:
    """``reset(seed=seed, options=options)``'s inputs checked (the hidden physics pops its own options)."""
    seed = check_seed(seed)
    options = check_reset_options(options, env.reset_options)
    env.hidden.take_options(seed, options)      # pops its own options
    given = goal = None
    if options.get("context") is not None:
        given = check_context(options["context"], env.context_keys,
                              cn.entry_check(env.camera_noise, env.hidden.check_context_entry))
    if options.get("goal") is not None:
        goal = check_goal(options["goal"], "options['goal']")
    record = options.get("record_trajectory")
    record = env.record_trajectory if record is None else check_flag(record, "options['record_trajectory']")
    return ResetInputs(seed, given, goal, record)


def episode_context(env, inputs: ResetInputs) -> tuple[dict[str, Any], str]:
    """The episode's context (given or sampled with ``env.np_random``, the given goal in place) and the name of
    where its goal came from (for error messages); ``ValueError`` if the goal is outside ``env.goal_region``."""
    given, goal = inputs.context, inputs.goal
    context = given if given is not None else env.sample_context(env.np_random)
    what = ("options['goal']" if goal is not None else
            "options['context']['goal']" if given is not None else f"{env.task_name}: the sampled goal")
    if goal is not None:
        context["goal"] = goal
    context["goal"] = np.asarray(context["goal"], dtype=np.float64)
    check_goal_region(context["goal"], env.goal_region, env.task_name, what)
    return context, what


def check_start_distance(env, goal: np.ndarray, start_pos: np.ndarray, d0: float, what: str) -> None:
    """``ValueError`` unless the object's start distance ``d0`` from ``goal`` (xy) is at least
    ``env.min_goal_distance``."""
    if not d0 >= env.min_goal_distance:
        raise ValueError(f"{what} = {_xy(goal)} is {d0:.3g} m from the {env.object_name}'s start "
                         f"{_xy(start_pos[:2])}; goals must be at least {env.min_goal_distance} m from it (the reward "
                         f"1 - d/d0 divides by that distance)")
