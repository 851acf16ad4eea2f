"""PhyPlan on the hidden-physics tasks: the conditioned skills, the parameter spaces and a predictor at given physics.

On ``PhyPlan/<Task>Varied-v0`` (task names ``launch-varied``, ...) the planner scores actions with the varied
chains (composed by :mod:`phyplan_agents.phyplan.composer`), whose skills take the hidden physical parameters as
inputs.
:class:`PhysicsPredictor` is that chain at one assumed physics ``theta``: it has the interface of
:class:`~phyplan_agents.phyplan.predictor.ChainPredictor` (so ``phyplan``, ``phyplan-position`` and
``phyplan-nogp`` plan with it unchanged, at the nominal physics, i.e. what an agent that ignores the hidden physics
assumes), and ``phyplan-sysid`` moves ``theta`` to its estimate after every attempt.

:func:`parameter_space` gives the identification's view of a task's hidden parameters: the search box (the hull of
the training and test spaces, :mod:`phyplan_envs.hidden_physics`), the prior (the nominal values, the training
space's centre) and which are searched on a log scale.
"""
from __future__ import annotations

from types import SimpleNamespace
from typing import Any

import numpy as np

from phyplan_envs import hidden_physics as hp
from phyplan_envs.hidden_physics import is_varied

from .composer import chain_for, composed
from .identify import Parameter
from .predictor import ChainPredictor

CONDITIONED_SKILLS = ("swing", "throw", "hit_cond", "hit_free_cond", "slide_cond", "bounce_cond", "bounce_general_cond",
                      "bounce_wall_cond",
                      # Paddles' (PaddlesVaried hides only the paddles' restitution: its hit is the nominal one)
                      "hit", "swing_wide", "hit_wide", "throw_wide", "glide", "bounce_general_low_cond",
                      "bounce_general_exact_cond", "hit_free", "hit_free_slow")

_CACHE: dict[str, Any] = {}


def load_conditioned_skills():
    """The shipped skills the varied chains use: ``swing`` and ``throw`` (the nominal PINNs) and the conditioned
    ``hit_cond``, ``hit_free_cond``, ``slide_cond`` (PINN), ``bounce_cond``, ``bounce_general_cond`` and
    ``bounce_wall_cond`` (loaded once per process)."""
    if "skills" not in _CACHE:
        from phyplan_agents.skills import load_skill

        _CACHE["skills"] = SimpleNamespace(**{name: load_skill(name) for name in CONDITIONED_SKILLS})
    return _CACHE["skills"]


def parameter_space(task: str) -> tuple[Parameter, ...]:
    """The hidden parameters of a varied task as :class:`~phyplan_agents.phyplan.identify.Parameter` s, in the
    chain's column order: search box = hull of the training and test spaces, prior = the nominal value."""
    if not is_varied(task):
        raise ValueError(f"task {task!r} has no hidden physics; varied tasks: {', '.join(hp.varied_tasks())}")
    return tuple(Parameter(p.name, *p.hull(), float(p.nominal), log=p.log) for p in hp.parameters(task))


class PhysicsPredictor(ChainPredictor):
    """A varied task's chain at assumed physics ``theta`` (the values of the task's hidden parameters, in the order
    :func:`phyplan_envs.hidden_physics.parameter_names` gives).

    ``final_xy(actions)`` / ``reward(actions)`` score actions ``(N, A)`` under ``theta``;
    ``final_xy_rows(rows)`` scores rows ``(N, A + P)`` of actions and physics (one physics per row).
    """

    def __init__(self, task: str, skills: Any = None, theta=None, scene=None, **kwargs):
        if not is_varied(task):
            raise ValueError(f"task {task!r} has no hidden physics; varied tasks: {', '.join(hp.varied_tasks())}")
        self.task = task
        self.space = parameter_space(task)
        chain = composed(task, scene)
        super().__init__(chain_for(task, scene), skills if skills is not None else load_conditioned_skills(),
                         chain.facts, **kwargs)
        self.theta = np.array([p.prior for p in self.space]) if theta is None else theta

    @property
    def theta(self) -> np.ndarray:
        return self._theta.copy()

    @theta.setter
    def theta(self, value) -> None:
        v = np.asarray(value, dtype=np.float64).reshape(-1)
        if v.shape != (len(self.space),) or not np.all(np.isfinite(v)):
            raise ValueError(f"theta must be {len(self.space)} finite values for {[p.name for p in self.space]}, "
                             f"got {value!r}")
        self._theta = v

    def final_xy_rows(self, rows) -> np.ndarray:
        """Predicted final xy (N, 2) for rows ``(N, A + P)``: an action and a physics per row."""
        return super().final_xy(rows)

    def final_xy(self, actions) -> np.ndarray:
        a = np.atleast_2d(np.asarray(actions, dtype=np.float64))
        return super().final_xy(np.hstack([a, np.tile(self._theta, (len(a), 1))]))
