"""``phyplan-perception-sysid``: perception plus online identification of the hidden physics (the varied track).

``phyplan-sysid`` (:mod:`phyplan_agents.phyplan.sysid`) fits the hidden parameters to the landings it reads from
the step's ``info["final_pos"]``; an agent that sees only pictures and rewards cannot read that. This one plans from
the picture as ``phyplan-perception`` does and identifies the physics from what it has:

* **the rewards** (always): an attempt's reward gives the landing's distance from the goal read from the picture,
  ``d = (1 - r) d0``. The MAP fit of :class:`~phyplan_agents.phyplan.identify.ParameterFit` runs on those
  distances: its predictor returns ``(|f(a, theta) - g|, 0)`` and the observed rows are ``(d, 0)``, so its objective
  is ``sum_k ((|f(a_k, theta) - g| - d_k) / sigma)^2`` plus the prior term. One distance cannot tell an overshoot
  from a shortfall; the fit takes the one its prior favours and the next attempt, planned at that estimate, tells.
* **the landings** when the caller passes the picture after each attempt (``observe(..., obs=after)``; the harness
  does not) and the object is seen in every one: then the fit is ``phyplan-sysid``'s on the xy landings.

After the fit the chain moves to the estimate and GP-UCB is refitted on every attempt's reward residual against the
identified chain (the residual this agent can compute). While the goal is not seen (the fallback of
``phyplan-perception``: its belief over goal centres), the landings the belief uses are the chain's and the physics
stays nominal: identifying both from distances to an unknown goal is not attempted.
"""
from __future__ import annotations

from typing import Any, Mapping

import numpy as np

from phyplan_envs.hidden_physics import is_varied

from ..base import Agent, TaskInfo
from ..phyplan.identify import ParameterFit
from ..phyplan.varied import PhysicsPredictor
from .agent import PhyPlanPerceptionAgent
from .goal_belief import landing_of


class PhyPlanPerceptionSysIdAgent(PhyPlanPerceptionAgent):
    """``phyplan-perception`` with online identification of the hidden physics (module docstring).

    Args:
        noise: the identification's error scale sigma (m; default 0.01), on distances or landings.
        prior_width: its prior's standard deviation in unit-box coordinates (default 0.5).
        **kwargs: the options of :class:`~phyplan_agents.perception.agent.PhyPlanPerceptionAgent`.
    """

    name = "phyplan-perception-sysid"

    def __init__(self, noise: float = 0.01, prior_width: float = 0.5, **kwargs: Any):
        super().__init__(**kwargs)
        if noise <= 0 or prior_width <= 0:
            raise ValueError(f"noise and prior_width must be positive, got {noise}, {prior_width}")
        self.noise = float(noise)
        self.prior_width = float(prior_width)
        self.fitter: ParameterFit | None = None
        self._by_distance = True
        self._side = 0

    def setup(self, task: TaskInfo, seed: int = 0) -> None:
        if not is_varied(task.task):
            raise ValueError(f"{self.name} identifies hidden physics; task {task.task!r} has none (use a varied "
                             f"task, e.g. {task.task}-varied, or phyplan-perception)")
        super().setup(task, seed)
        if not isinstance(self.predictor, PhysicsPredictor):
            raise TypeError(f"{self.name} needs the varied chain's PhysicsPredictor")
        self.fitter = ParameterFit(self.predictor.space, self._predict_rows, noise=self.noise,
                                   prior_width=self.prior_width)

    def _predict_rows(self, actions: np.ndarray, theta: np.ndarray) -> np.ndarray:
        self.count("skill_evals", len(actions))
        xy = self.predictor.final_xy_rows(np.hstack([actions, theta]))
        if not self._by_distance:
            return xy
        g, s = self.predictor.goal, self.state[2:4]
        d = np.linalg.norm(xy - g, axis=1)
        if self._side == 0:
            return np.column_stack([d, np.zeros_like(d)])
        d0 = float(np.linalg.norm(g - s))
        progress = (xy - s) @ (g - s) / d0                 # how far along the start -> goal line the landing is
        return np.column_stack([d, np.maximum(0.0, self._side * (d0 - progress))])

    def begin_context(self, obs: Any, info: Mapping[str, Any], simulator=None) -> None:
        super().begin_context(obs, info, simulator)
        self.predictor.theta = self.fitter.prior
        self._picture_landings: list[np.ndarray | None] = []
        self._alternatives: list[np.ndarray] = []
        self.estimates: list[np.ndarray] = []

    def _fit(self, actions: np.ndarray, finals: np.ndarray) -> np.ndarray:
        """The MAP fit; on distances also restricted to physics under which every landing so far was long
        (``_side`` +1) or short (-1) of the goal, the estimate being the one of the three that explains the
        distances best (the grid search alone tends to stay in the basin its prior favours)."""
        if not self._by_distance:
            return self.fitter.fit(actions, finals)
        fits = []
        for side in (0, 1, -1):
            self._side = side
            fits.append(self.fitter.fit(actions, finals))
        self._side = 0
        costs = [self.fitter.cost(actions, finals, th) for th in fits]
        order = np.argsort(costs, kind="stable")
        self._alternatives = [fits[k] for k in order[1:]]
        return fits[int(order[0])]

    def act(self) -> np.ndarray:
        """The planner's action; if it repeats an earlier attempt (the distances cannot tell overshoot from
        shortfall and that attempt's reward would come again, teaching nothing), the next-best physics of the fit
        (:meth:`_fit`) is tried instead."""
        action = super().act()
        tried = [h[0] for h in getattr(self, "history", [])]
        span = self.task.action_high - self.task.action_low
        for alt in list(getattr(self, "_alternatives", [])):
            if not any(np.all(np.abs(action - a) <= 1e-3 * span) for a in tried):
                break
            self.predictor.theta = alt
            self._alternatives.remove(alt)
            self.count("sysid_switches")
            action = super().act()
        if tried and any(np.all(np.abs(action - a) <= 1e-3 * span) for a in tried):
            # every estimate leads back to a tried action: plan as phyplan-perception does (the nominal chain and
            # GP-UCB on its reward error), which moves on from an attempt that missed
            self.predictor.theta = self.fitter.prior
            self.count("sysid_nominal")
            if self.adapt:
                acts = np.vstack(tried)
                res = np.array([h[1] for h in self.history]) - self.predicted_reward(acts)
                if np.all(np.isfinite(res)):
                    self.gp.set_data(acts, res)
            action = super().act()
        return action

    @property
    def theta(self) -> dict[str, float]:
        """The current estimate of the hidden parameters, by name."""
        return dict(zip(self.fitter.names, self.predictor.theta.tolist()))

    def observe(self, action: np.ndarray, reward: float, info: Mapping[str, Any], obs: Any = None) -> None:
        if self.belief is not None:                     # the goal is not seen: phyplan-perception's fallback
            super().observe(action, reward, info, obs)
            return
        Agent.observe(self, action, reward, info)
        self._picture_landings.append(landing_of(obs, self._camera, self._facts, self._reader))
        actions = np.vstack([h[0] for h in self.history])
        rewards = np.array([h[1] for h in self.history])
        self._by_distance = any(p is None for p in self._picture_landings)
        if self._by_distance:
            d = (1.0 - rewards) * self.predictor.initial_distance
            finals = np.column_stack([d, np.zeros_like(d)])
        else:
            finals = np.vstack(self._picture_landings)
        self.predictor.theta = self._fit(actions, finals)
        self.estimates.append(self.predictor.theta)
        if not self.adapt:
            return
        residuals = rewards - self.predicted_reward(actions)
        keep = np.isfinite(residuals)
        if keep.any():
            self.gp.set_data(actions[keep], residuals[keep])
        else:
            self.gp.reset()
