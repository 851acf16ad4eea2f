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
   docs/varied-track.md, *Agents on the varied track*);
3. **polishes** the best attempt so far (our addition beyond the paper; ``polish=None`` turns it off). Global plans
   go on while each beats every earlier attempt. After one that does not, and once the best attempt has reached
   reward ``polish``, the next attempt is a local step instead: PhyPlan's batched refinement started at the best
   attempt's action, in a box of ``polish_width`` MCTS grid cells either side, scored by the identified chain's
   landing moved by the best attempt's landing error (real minus predicted): a correction of a real landing by the
   chain's local response to the action, with no exploration bonus. Where the chain has no prediction for the best
   attempt, the attempt is planned globally. A trust region: a polishing step that beats every earlier attempt
   doubles the box (to at most :data:`MAX_TRUST` times its initial size) and polishes again; one that does not
   halves it and hands the next attempt to the global plan. Global plans keep GP-UCB's exploration (another basin
   can be better) and, where the identified chain is right, solve the task at once; polishing turns a near miss
   into a hit where the chain's absolute landing is off but its local response is right (edge contacts,
   extrapolated physics).

4. **explores** instead of repeating itself while the best attempt's reward is below ``explore`` (0.95 by default:
   no solution yet, as ``search_until`` and the suite's certificates count one; beyond the paper): the env is
   deterministic, so an attempt that repeats an earlier action (within :data:`REPEAT_TOL` of each dimension's range)
   neither improves the best attempt nor tells the physics apart. Short of a solution that happens where the
   landings so far fit several physics equally well and, at the estimate, no other action scores better (e.g. a goal
   nearer than the estimate can reach). Such an attempt is replaced by an optimistic one: among the physics that
   explain the landings about as well as the estimate
   (:meth:`~phyplan_agents.phyplan.identify.ParameterFit.plausible`, within :data:`EXPLORE_WITHIN`; at most
   :data:`EXPLORE_PHYSICS`), the action and physics whose predicted reward is the highest, over
   :data:`EXPLORE_CANDIDATES` random actions (half across the action box, half in the polishing box around the best
   attempt). Its landing then confirms that physics or rules it out.

Global planning is PhyPlan's (MCTS with K iterations and D + 1 children, then the batched refinement), scored by the
identified chain plus the GP-UCB correction, with up to 4 searches per decision (``searches``; another search only
while the best plan scores below ``search_until``, 0.95: where the identified chain rates no candidate a
solution). The first attempt uses the nominal physics (the training space's centre), like ``phyplan``.
"""
from __future__ import annotations

from typing import Any, Mapping

import numpy as np

from phyplan_envs.hidden_physics import is_varied

from ..base import Agent, TaskInfo
from .agent import PhyPlanAgent
from .identify import ParameterFit
from .mcts import refine
from .varied import PhysicsPredictor


MAX_TRUST = 4.0     # the polishing box grows to at most this many times its initial half-width
REPEAT_TOL = 1e-3   # an action within this fraction of every dimension's range of an earlier one repeats it
EXPLORE_WITHIN = 4.0       # sigma^2: physics whose fit is this close to the best are plausible (two sigma of one
                           # landing's error)
EXPLORE_PHYSICS = 16       # at most this many of them are tried ...
EXPLORE_CANDIDATES = 512   # ... on this many random actions


class PhyPlanSysIdAgent(PhyPlanAgent):
    """PhyPlan with online identification of the hidden physics (see the module docstring).

    Args:
        noise: the identification's landing error scale sigma (m; default 0.01, the chain's own error).
        prior_width: its prior's standard deviation in unit-box coordinates (default 0.5: weak; it only breaks ties
            between physics that explain the landings equally well).
        residual: what the GP models after the identification: ``"position"`` (default; the landing-position
            error) or ``"reward"`` (the paper's reward error).
        polish: the reward from which the best attempt is polished (default 0.5; None = never: PhyPlan's global
            plan every attempt).
        polish_width: the polishing box's initial half-width in MCTS grid cells, ``(high - low) / D`` (default 2).
        explore: while the best reward so far is below this, an attempt that would repeat an earlier one is
            replaced by an optimistic one (default 0.95; None = never; the module docstring, item 4).
        **kwargs: the planner's options (:class:`~phyplan_agents.phyplan.agent.PhyPlanAgent`); here ``searches``
            defaults to 4.
    """

    name = "phyplan-sysid"

    def __init__(self, noise: float = 0.01, prior_width: float = 0.5, polish: float | None = 0.5,
                 polish_width: float = 2.0, explore: float | None = 0.95, **kwargs: Any):
        if kwargs.get("scorer", "chain") != "chain":
            raise ValueError("phyplan-sysid identifies the physics of the skill chain; it needs scorer='chain'")
        kwargs.setdefault("residual", "position")
        kwargs.setdefault("searches", 4)
        super().__init__(**kwargs)
        if noise <= 0 or prior_width <= 0:
            raise ValueError(f"noise and prior_width must be positive, got {noise}, {prior_width}")
        self.noise = float(noise)
        self.prior_width = float(prior_width)
        if polish is not None and not (isinstance(polish, (int, float)) and np.isfinite(polish) and polish <= 1):
            raise ValueError(f"polish must be a finite reward <= 1 or None (never polish), got {polish!r}")
        if not (isinstance(polish_width, (int, float)) and np.isfinite(polish_width) and polish_width > 0):
            raise ValueError(f"polish_width must be a positive number of grid cells, got {polish_width}")
        self.polish = None if polish is None else float(polish)
        self.polish_width = float(polish_width)
        if explore is not None and (isinstance(explore, bool) or not isinstance(explore, (int, float))
                                    or not np.isfinite(explore)):
            raise ValueError(f"explore must be a finite reward or None (never explore), got {explore!r}")
        self.explore = None if explore is None else float(explore)
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
        self._trust = self.polish_width      # the polishing box's half-width, in MCTS grid cells
        self._polishing = False              # the attempt in flight was planned by polishing
        self._polish_next = False            # the next attempt polishes (if the best attempt reached ``polish``)

    @property
    def theta(self) -> dict[str, float]:
        """The current estimate of the hidden parameters, by name."""
        return dict(zip(self.fitter.names, self.predictor.theta.tolist()))

    def observe(self, action: np.ndarray, reward: float, info: Mapping[str, Any]) -> None:
        Agent.observe(self, action, reward, info)
        self._update_trust(float(reward))
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

    # -- polishing --------------------------------------------------------------------------------------------------
    def _best_attempt(self) -> int:
        rewards = np.array([h[1] for h in self.history], dtype=np.float64)
        return int(np.argmax(np.where(np.isfinite(rewards), rewards, -np.inf)))

    def polish_score(self, actions: np.ndarray) -> np.ndarray:
        """The reward (N,) of actions (N, A) where the identified chain's landing is moved by the best attempt's
        landing error (real minus predicted, at the current estimate): the chain's response to the action, applied
        to a real landing. ``nan`` before any attempt or where the chain has no prediction for the best attempt."""
        actions = np.atleast_2d(np.asarray(actions, dtype=np.float64))
        if not self.history:
            return np.full(len(actions), np.nan)
        i = self._best_attempt()
        start = np.asarray(self.history[i][0], dtype=np.float64)
        self.count("skill_evals", len(actions) + 1)
        offset = self.finals[i] - self.predictor.final_xy(start[None])[0]
        if not np.all(np.isfinite(offset)):
            return np.full(len(actions), np.nan)
        return self.predictor.reward_of_xy(self.predictor.final_xy(actions) + offset)

    def plan(self) -> tuple[np.ndarray, float]:
        """A polishing step around the best attempt or PhyPlan's global plan (the module docstring's rule), and, where
        that would repeat an earlier attempt, an optimistic one instead (item 4)."""
        action, value = self._plan_step()
        if (self.explore is not None and self.history and self.history[self._best_attempt()][1] < self.explore
                and self._repeats(self.clip(action))):
            return self.explore_plan() or (action, value)
        return action, value

    def _repeats(self, action: np.ndarray) -> bool:
        span = self.task.action_high - self.task.action_low
        return any(np.all(np.abs(action - np.asarray(h[0], dtype=np.float64)) <= REPEAT_TOL * span)
                   for h in self.history)

    def explore_plan(self) -> tuple[np.ndarray, float] | None:
        """The optimistic attempt (the module docstring, item 4): ``(action, its predicted reward)`` under the
        plausible physics that rates it highest (None if every candidate repeats an attempt). ``last_plan`` records
        that physics and the plausible set's size."""
        actions = np.vstack([h[0] for h in self.history])
        physics = self.fitter.plausible(actions, np.vstack(self.finals), EXPLORE_WITHIN, EXPLORE_PHYSICS)
        if len(physics) == 0:
            physics = self.predictor.theta[None]
        lo, hi = self.task.action_low, self.task.action_high
        width = self._trust * (hi - lo) / self.discretisation
        best = np.asarray(self.history[self._best_attempt()][0], dtype=np.float64)
        half = EXPLORE_CANDIDATES // 2
        local = np.clip(best + width * (2.0 * self.rng.random((EXPLORE_CANDIDATES - half, len(lo))) - 1.0), lo, hi)
        cands = np.vstack([self.uniform_actions(half), local])
        cands = cands[[not self._repeats(a) for a in cands]]
        if len(cands) == 0:
            return None
        xy = self._predict_rows(np.tile(cands, (len(physics), 1)), np.repeat(physics, len(cands), axis=0))
        rewards = self.predictor.reward_of_xy(xy)            # physics j's rows are j * len(cands) onwards
        k = int(np.argmax(rewards))
        action, value = cands[k % len(cands)], float(rewards[k])
        self.last_plan = {"explore_physics": physics[k // len(cands)].copy(), "plausible": len(physics),
                          "action": action.copy(), "score": value}
        self._polishing = False
        return action.copy(), value

    def _plan_step(self) -> tuple[np.ndarray, float]:
        """A polishing step around the best attempt (the module docstring's rule), else PhyPlan's global plan."""
        start = None
        if self.polish is not None and self.history and self._polish_next:
            i = self._best_attempt()
            if self.history[i][1] >= self.polish:
                start = np.asarray(self.history[i][0], dtype=np.float64)
        start_score = np.nan if start is None else float(self.polish_score(start[None])[0])
        self._polishing = bool(np.isfinite(start_score))
        if not self._polishing:
            return super().plan()
        lo, hi = self.task.action_low, self.task.action_high
        width = self._trust * (hi - lo) / self.discretisation
        action, value, n = refine(self.polish_score, start, start_score, lo, hi, width,
                                  points=self.refine_grid_points(), rounds=self.refine_rounds,
                                  shrink=self.refine_shrink, rng=self.rng)
        self.last_plan = {"polish_start": start, "trust_cells": self._trust, "action": action.copy(), "score": value,
                          "refine_evaluations": n}
        return action, value

    def _update_trust(self, reward: float) -> None:
        """After an attempt: whether the next one polishes, and the trust region's size (the module docstring)."""
        earlier = [h[1] for h in self.history[:-1] if np.isfinite(h[1])]
        improved = bool(np.isfinite(reward) and (not earlier or reward > max(earlier)))
        if self._polishing:
            self._trust = min(2.0 * self._trust, MAX_TRUST * self.polish_width) if improved else 0.5 * self._trust
            self._polish_next = improved           # polish on while it improves; after a failed step, plan globally
        else:
            self._polish_next = not improved       # plan globally while global plans improve
