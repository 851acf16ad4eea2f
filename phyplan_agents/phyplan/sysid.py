"""``phyplan-sysid``: PhyPlan with online system identification of the hidden physics (beyond the paper).

The paper's PINN learns the friction coefficient as a trainable constant; on the hidden-physics tasks the friction,
the restitutions and the bob mass change per context. This agent plans with the parameter-conditioned chain
(:class:`~phyplan_agents.phyplan.varied.PhysicsPredictor`) and, after every attempt:

1. **identifies** the hidden parameters: the MAP fit of :class:`~phyplan_agents.phyplan.identify.ParameterFit`
   to all landings seen so far in this context (grid over the hull of the training and test spaces, then
   least squares), the chain's ``theta`` moves to the estimate;
2. **re-fits GP-UCB** on what the identified chain still gets wrong: the residuals of every attempt so far against
   the chain *at the new estimate*, so the GP models only what the parameters cannot explain. By default the
   residual is the landing position's (``residual="position"``, in the identification's own units), because the
   paper's reward residual cannot tell which way the object missed (the measurement behind this default:
   docs/varied-track.md, *Agents on the varied track*).

Planning is PhyPlan's (MCTS with K iterations and D + 1 children, then the batched refinement), scored by the
identified chain plus the GP-UCB correction. The first attempt uses the nominal physics (the training space's
centre), like ``phyplan``.
"""
from __future__ import annotations

from typing import Any, Mapping

import numpy as np

from phyplan_envs.hidden_physics import is_varied

from ..base import Agent, TaskInfo
from .agent import PhyPlanAgent
from .identify import ParameterFit
from .varied import PhysicsPredictor


class PhyPlanSysIdAgent(PhyPlanAgent):
    """PhyPlan with online identification of the hidden physics (see the module docstring).

    Args:
        noise: the identification's landing error scale sigma (m; default 0.01, the chain's own error).
        prior_width: its prior's standard deviation in unit-box coordinates (default 0.5: weak; it only breaks ties
            between physics that explain the landings equally well).
        residual: what the GP models after the identification: ``"position"`` (default; the landing-position
            error) or ``"reward"`` (the paper's reward error).
        **kwargs: the planner's options (:class:`~phyplan_agents.phyplan.agent.PhyPlanAgent`).
    """

    name = "phyplan-sysid"

    def __init__(self, noise: float = 0.01, prior_width: float = 0.5, **kwargs: Any):
        if kwargs.get("scorer", "chain") != "chain":
            raise ValueError("phyplan-sysid identifies the physics of the skill chain; it needs scorer='chain'")
        kwargs.setdefault("residual", "position")
        super().__init__(**kwargs)
        if noise <= 0 or prior_width <= 0:
            raise ValueError(f"noise and prior_width must be positive, got {noise}, {prior_width}")
        self.noise = float(noise)
        self.prior_width = float(prior_width)
        self.fitter: ParameterFit | None = None

    def setup(self, task: TaskInfo, seed: int = 0) -> None:
        if not is_varied(task.task):
            raise ValueError(f"phyplan-sysid identifies hidden physics; task {task.task!r} has none (use a "
                             f"varied task, e.g. {task.task}-varied)")
        super().setup(task, seed)
        if not isinstance(self.predictor, PhysicsPredictor):
            raise TypeError("phyplan-sysid needs the varied chain's PhysicsPredictor")
        self.fitter = ParameterFit(self.predictor.space, self._predict_rows, noise=self.noise,
                                   prior_width=self.prior_width)

    def _predict_rows(self, actions: np.ndarray, theta: np.ndarray) -> np.ndarray:
        self.count("skill_evals", len(actions))
        return self.predictor.final_xy_rows(np.hstack([actions, theta]))

    def begin_context(self, obs: Any, info: Mapping[str, Any], simulator=None) -> None:
        super().begin_context(obs, info, simulator)
        self.predictor.theta = self.fitter.prior
        self.finals: list[np.ndarray] = []
        self.estimates: list[np.ndarray] = []

    @property
    def theta(self) -> dict[str, float]:
        """The current estimate of the hidden parameters, by name."""
        return dict(zip(self.fitter.names, self.predictor.theta.tolist()))

    def observe(self, action: np.ndarray, reward: float, info: Mapping[str, Any]) -> None:
        Agent.observe(self, action, reward, info)
        final = np.asarray(info.get("final_pos", np.full(2, np.nan)), dtype=np.float64).reshape(-1)[:2]
        self.finals.append(final)
        actions = np.vstack([h[0] for h in self.history])
        finals = np.vstack(self.finals)
        self.predictor.theta = self.fitter.fit(actions, finals)
        self.estimates.append(self.predictor.theta)
        if not self.adapt:
            return
        self.count("skill_evals", len(actions))
        predicted = self.predictor.final_xy(actions)
        if self.residual == "position":
            residuals = finals - predicted
        else:
            rewards = np.array([h[1] for h in self.history])
            residuals = (rewards - self.predictor.reward_of_xy(predicted))[:, None]
        keep = np.all(np.isfinite(residuals), axis=1)
        if not keep.any():
            self.gp.reset()
            return
        self.gp.set_data(actions[keep], residuals[keep] if self.residual == "position" else residuals[keep, 0])
