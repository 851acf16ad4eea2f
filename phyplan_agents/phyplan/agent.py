"""The PhyPlan agent (the paper's Algorithms 1-3) and its registered variants.

* ``phyplan``: physics-informed MCTS scored by the task's skill chain (learnt skill models), GP-UCB adaptation on the
  chain's reward error after every real attempt.
* ``phyplan-nogp``: the same without adaptation (the ablation of the paper's Fig. 10).
* ``phyplan-position``: GP-UCB on the chain's landing-position error instead (our addition beyond the paper).
* ``phyplan-sysid`` (:mod:`.sysid`): online identification of the hidden physics on the varied tasks.
* ``phyplan-sim``: the same planner with the MuJoCo simulator in place of the skill chain (the comparison of the
  paper's Fig. 9). Every candidate it scores is one counted simulator call.

Per attempt (:meth:`PhyPlanAgent.act`): build a fresh tree, run K MCTS iterations with D + 1 evenly spaced children
per expansion (:class:`~phyplan_agents.phyplan.mcts.MCTS`), then refine the best action found with a batched
pattern search (:func:`~phyplan_agents.phyplan.mcts.refine`; our addition beyond the paper, ``refine_rounds=0``
turns it off). After the attempt (:meth:`PhyPlanAgent.observe`) the GP is refitted on (action, real reward -
chain-predicted reward).

On the hidden-physics tasks (``<task>-varied``) the chain is the parameter-conditioned one
(:class:`~phyplan_agents.phyplan.varied.PhysicsPredictor`) at the nominal physics.

Resources reported by :meth:`stats`: ``skill_evals`` (candidate actions scored by the skill chain: one chain
rollout each), ``sim_calls`` (simulator calls through the counted :class:`~phyplan_agents.base.Simulator`) and
``plan_seconds`` (wall time spent in ``act``).
"""
from __future__ import annotations

import time
from typing import Any, Mapping

import numpy as np

from phyplan_envs.hidden_physics import is_varied

from ..base import Agent, Simulator, TaskInfo, scene_arguments
from ..gp_ucb import BETA, POSITION_PRIOR, REWARD_PRIOR, ResidualGP
from .mcts import MCTS, refine
from .predictor import ChainPredictor
from .varied import PhysicsPredictor

_SKILL_CACHE: dict[str, Any] = {}


def load_default_skills(kinds: Mapping[str, str] | None = None):
    """The pretrained skill models shipped with the package (loaded once per process and choice of kinds).

    ``kinds`` picks other shipped model kinds per skill, e.g. ``{"swing": "nn"}`` (default: each skill's default
    kind, PINN for swing/slide/throw). The namespace has the conditioned skills, the :class:`SkillSet`'s and the
    Paddles task's (``swing_wide``, ``hit_wide``, ``throw_wide``, ``glide``, ``bounce_general_low``,
    ``bounce_general_low_cond``) and ``hit_free`` (the hit's physical hand-over).
    """
    key = repr(sorted((kinds or {}).items()))
    if key not in _SKILL_CACHE:
        try:
            from phyplan_agents.skills import SkillSet
        except ImportError as exc:  # pragma: no cover - depends on the installation
            raise RuntimeError(f"the PhyPlan agent needs the skill models of phyplan_agents.skills: {exc}") from exc
        from types import SimpleNamespace

        from .varied import load_conditioned_skills

        # the nominal skills (of the chosen kinds) and the conditioned ones, for contacts of a given restitution
        # (e.g. LaunchBounce's impact pair), and the Paddles task's (skills.swing_wide, ..., skills.glide)
        nominal = SkillSet.load(kinds=dict(kinds or {}))
        _SKILL_CACHE[key] = SimpleNamespace(**{**vars(load_conditioned_skills()), **dict(nominal.all_items())})
    return _SKILL_CACHE[key]


def state_from_obs(obs: Any, obs_mode: str) -> np.ndarray:
    """The state vector of a phyplan observation (``"state"`` or ``"state_image"`` mode)."""
    if obs_mode == "image" or (isinstance(obs, np.ndarray) and obs.ndim == 3):
        raise ValueError("the PhyPlan agent reads the state observation; make the env with obs_mode='state' or "
                         "'state_image' (to plan from RGB-D pictures use the agent 'phyplan-perception')")
    if isinstance(obs, Mapping):
        if "state" not in obs:
            raise ValueError(f"observation dict has no 'state' entry (keys: {sorted(obs)})")
        obs = obs["state"]
    return np.asarray(obs, dtype=np.float64)


class PhyPlanAgent(Agent):
    """PhyPlan: skill-chain MCTS with GP-UCB adaptation.

    Args:
        iterations: MCTS iterations per attempt, K (default 10: the paper's "typical K").
        discretisation: the discretisation factor D; each expansion adds D + 1 evenly spaced children, both bounds
            included (default 20: the paper's typical D; D + 1 = 21 as in the reference code).
        c: UCB1 exploration constant (default 1, the reference code's).
        beta: GP-UCB weight of sigma (default 0.25, the paper's).
        adapt: fit the GP on the chain's error after each attempt (default true; false = ``phyplan-nogp``).
        residual: what the GP models. ``"reward"`` (default, the paper's Algorithm 2): real reward - predicted
            reward, and candidates score ``r_hat + mu + sqrt(beta) * sigma``. ``"position"`` (our addition beyond
            the paper): the error of the predicted final xy (from ``info["final_pos"]``), and candidates score the
            reward of the corrected position ``xy_hat + mu_xy`` plus ``sqrt(beta) * sigma_xy / d0``. Only with the
            skill chain.
        refine_rounds: rounds of the batched local search after MCTS (default 4; 0 = the paper's planner alone).
        refine_points: grid values per action dimension in each refinement round (default: 11 for tasks with up to
            2 action dimensions, 9 for 3).
        refine_width: half-width of the first refinement box in MCTS grid cells, (high - low) / D (default 2).
        refine_shrink: box shrink factor per round (default 0.3).
        skills: the skill models (an object with ``swing``, ``slide``, ``throw``, ``hit``, ``bounce``); default the
            shipped pretrained ones (``phyplan_agents.skills.SkillSet.load()``).
        skill_kinds: with the shipped skills, which model kind per skill, e.g. ``{"swing": "nn", "slide": "nn",
            "throw": "nn"}`` for the data-only networks (default: PINN for swing, slide and throw).
        scorer: ``"chain"`` (skill chain) or ``"sim"`` (the real simulator; ``phyplan-sim``).
        gp_restarts: optimiser restarts of the GP's hyperparameter fit (default 2).
        searches: at most this many searches per decision (default 1: the paper's one). A search (MCTS and the
            refinement) whose plan scores below ``search_until`` is followed by another, from where the rollout
            generator stands, and the best plan of them is taken (our addition beyond the paper: more search only
            where the chain rates no candidate a solution).
        search_until: the score at which a plan ends the searches (default 0.95).
    """

    name = "phyplan"

    def __init__(self, iterations: int = 10, discretisation: int = 20, c: float = 1.0, beta: float = BETA,
                 adapt: bool = True, residual: str = "reward", refine_rounds: int = 4,
                 refine_points: int | None = None, refine_width: float = 2.0, refine_shrink: float = 0.3,
                 skills: Any = None, skill_kinds: Mapping[str, str] | None = None, scorer: str = "chain",
                 gp_restarts: int = 2, searches: int = 1, search_until: float = 0.95):
        super().__init__()
        if int(iterations) < 1:
            raise ValueError(f"iterations (K) must be >= 1, got {iterations}")
        if int(discretisation) < 1:
            raise ValueError(f"discretisation (D) must be >= 1, got {discretisation}")
        if scorer not in ("chain", "sim"):
            raise ValueError(f"scorer must be 'chain' or 'sim', got {scorer!r}")
        if residual not in ("reward", "position"):
            raise ValueError(f"residual must be 'reward' or 'position', got {residual!r}")
        if residual == "position" and scorer != "chain":
            raise ValueError("residual='position' corrects the skill chain's predicted positions; it needs "
                             "scorer='chain'")
        if refine_rounds < 0 or (refine_points is not None and refine_points < 2):
            raise ValueError("refine_rounds must be >= 0 and refine_points >= 2")
        if not 0 < refine_shrink < 1:
            raise ValueError(f"refine_shrink must be in (0, 1), got {refine_shrink}")
        if isinstance(searches, bool) or not isinstance(searches, (int, np.integer)) or searches < 1:
            raise ValueError(f"searches must be a positive integer, got {searches!r}")
        if isinstance(search_until, bool) or not isinstance(search_until, (int, float)) or np.isnan(search_until):
            raise ValueError(f"search_until must be a score (inf: always all the searches), got {search_until!r}")
        self.searches = int(searches)
        self.search_until = float(search_until)
        self.iterations = int(iterations)
        self.discretisation = int(discretisation)
        self.c = float(c)
        self.beta = float(beta)
        self.adapt = bool(adapt)
        self.residual = residual
        self.refine_rounds = int(refine_rounds)
        self.refine_points = refine_points
        self.refine_width = float(refine_width)
        self.refine_shrink = float(refine_shrink)
        self.scorer_kind = scorer
        self.needs_simulator = scorer == "sim"
        self.gp_restarts = int(gp_restarts)
        self._skills = skills
        self.skill_kinds = dict(skill_kinds or {})
        if skills is not None and skill_kinds:
            raise ValueError("give either skills (an object) or skill_kinds (a choice of shipped models), not both")
        self.predictor: ChainPredictor | None = None
        self.gp: ResidualGP | None = None
        self.last_plan: dict[str, Any] = {}

    # -- life cycle -----------------------------------------------------------------------------------------------
    def setup(self, task: TaskInfo, seed: int = 0) -> None:
        super().setup(task, seed)
        if task.obs_mode == "image":
            raise ValueError(f"{self.name} reads the state observation, but the env was made with obs_mode='image'; "
                             f"use obs_mode='state' or 'state_image' (to plan from RGB-D pictures use the agent "
                             f"'phyplan-perception')")
        self._counters.setdefault("plan_seconds", 0.0)
        if self.scorer_kind == "chain" and is_varied(task.task):
            # a hidden-physics task: the parameter-conditioned chain at the nominal physics (what an agent that
            # ignores the hidden physics assumes); phyplan-sysid moves it to its estimate after every attempt
            if self.skill_kinds:
                raise ValueError(f"skill_kinds picks nominal skill models; {task.task} uses the conditioned ones")
            self.predictor = PhysicsPredictor(task.task, skills=self._skills,
                                              scene=scene_arguments(task.task, task.env_kwargs))
        elif self.scorer_kind == "chain":
            skills = self._skills if self._skills is not None else load_default_skills(self.skill_kinds)
            self.predictor = ChainPredictor.for_task(task.task, skills,
                                                     scene=scene_arguments(task.task, task.env_kwargs))
        self.gp = ResidualGP(task.action_low, task.action_high, beta=self.beta,
                             seed=int(self.rng.integers(2 ** 31 - 1)), n_restarts=self.gp_restarts,
                             prior=POSITION_PRIOR if self.residual == "position" else REWARD_PRIOR)

    def reseed(self, seed: int) -> None:
        """Reseed the rollout generator and the GP's optimiser (the harness calls this before every context)."""
        self.rng = np.random.default_rng(seed)
        if self.gp is not None:
            self.gp.seed = int(self.rng.integers(2 ** 31 - 1))

    def begin_context(self, obs: Any, info: Mapping[str, Any], simulator: Simulator | None = None) -> None:
        if self.task is None:
            raise RuntimeError("setup(task, seed) must be called before begin_context()")
        super().begin_context(obs, info, simulator)
        self.state = self.read_state(obs)
        if self.predictor is not None:
            self.predictor.set_context(self.state)
        elif simulator is None:
            raise ValueError(f"{self.name} plans with the real simulator and needs the harness's Simulator in "
                             f"begin_context(obs, info, simulator)")
        self.gp.reset()
        self.last_plan = {}

    def read_state(self, obs: Any) -> np.ndarray:
        """The state vector the chain reads, from the context's observation (``phyplan-perception``: from pixels)."""
        return state_from_obs(obs, self.task.obs_mode)

    # -- scoring --------------------------------------------------------------------------------------------------
    def predicted_reward(self, actions: np.ndarray) -> np.ndarray:
        """The uncorrected prediction (N,): skill-chain reward, or the simulator's reward for ``phyplan-sim``."""
        actions = np.atleast_2d(np.asarray(actions, dtype=np.float64))
        if self.predictor is not None:
            self.count("skill_evals", len(actions))
            return self.predictor.reward(actions)
        return self.simulator.evaluate_many(actions)

    def score(self, actions: np.ndarray) -> np.ndarray:
        """The planner's score (N,): predicted reward plus the GP-UCB correction (Algorithm 3, line 14)."""
        if not (self.adapt and self.gp.n > 0):
            return self.predicted_reward(actions)
        if self.residual == "reward":
            return self.predicted_reward(actions) + self.gp.correction(actions)
        actions = np.atleast_2d(np.asarray(actions, dtype=np.float64))
        self.count("skill_evals", len(actions))
        mu, sd = self.gp.predict(actions)
        xy = self.predictor.final_xy(actions) + mu
        bonus = np.sqrt(self.beta) * np.sqrt(np.mean(sd ** 2, axis=1)) / self.predictor.initial_distance
        return self.predictor.reward_of_xy(xy) + bonus

    # -- acting ---------------------------------------------------------------------------------------------------
    def plan(self) -> tuple[np.ndarray, float]:
        """One decision: up to ``searches`` searches (MCTS and the refinement; another only while the best plan scores
        below ``search_until``); returns (action, score) of the best plan."""
        best: dict[str, Any] | None = None
        for n in range(1, self.searches + 1):
            info = self.search()
            if best is None or info["score"] > best["score"]:
                best = info
            if best["score"] >= self.search_until:
                break
        best["searches"] = n
        self.last_plan = best
        return best["action"].copy(), best["score"]

    def search(self) -> dict[str, Any]:
        """One search: MCTS (K iterations, D + 1 children) and the refinement; its plan's record (``action``,
        ``score`` and the evaluations)."""
        lo, hi = self.task.action_low, self.task.action_high
        tree = MCTS(self.score, lo, hi, self.rng, n_children=self.discretisation + 1, c=self.c)
        action, value = tree.run(self.iterations)
        info = {"mcts_action": action.copy(), "mcts_score": value, "mcts_evaluations": tree.evaluations}
        if self.refine_rounds > 0:
            points = self.refine_grid_points()
            width = self.refine_width * (hi - lo) / self.discretisation
            action, value, n = refine(self.score, action, value, lo, hi, width, points=points,
                                      rounds=self.refine_rounds, shrink=self.refine_shrink, rng=self.rng)
            info["refine_evaluations"] = n
        info.update(action=action.copy(), score=float(value))
        return info

    def refine_grid_points(self) -> int:
        """Grid values per action dimension in a refinement round (``refine_points``, or its default)."""
        return self.refine_points or (11 if len(self.task.action_low) <= 2 else 9)

    def act(self) -> np.ndarray:
        if self.task is None or not hasattr(self, "state"):
            raise RuntimeError("setup() and begin_context() must be called before act()")
        t0 = time.perf_counter()
        action, _ = self.plan()
        self.count("plan_seconds", time.perf_counter() - t0)
        return self.clip(action)

    def observe(self, action: np.ndarray, reward: float, info: Mapping[str, Any]) -> None:
        super().observe(action, reward, info)
        if not self.adapt:
            return
        # Residual against the uncorrected prediction: the GP models the predictor's error (Algorithm 2, line 15;
        # the paper subtracts the corrected MCTS value, which would make the GP model its own previous output).
        a = np.asarray(action, dtype=np.float64)
        if self.residual == "position":
            final = np.asarray(info.get("final_pos", np.full(2, np.nan)), dtype=np.float64)[:2]
            self.count("skill_evals", 1)
            predicted_xy = self.predictor.final_xy(a[None])[0]
            if np.all(np.isfinite(final)) and np.all(np.isfinite(predicted_xy)):
                self.gp.add(a, final - predicted_xy)
            return
        if self.scorer_kind == "chain" and not np.all(np.isfinite(self.predictor.final_xy(a[None]))):
            return        # the chain has no prediction for this action: there is no error to learn
        predicted = float(self.predicted_reward(a[None])[0])
        if np.isfinite(predicted) and np.isfinite(reward):
            self.gp.add(a, float(reward) - predicted)


class PhyPlanNoGPAgent(PhyPlanAgent):
    """``phyplan-nogp``: PhyPlan without GP-UCB adaptation (the ablation of the paper's Fig. 10)."""

    name = "phyplan-nogp"

    def __init__(self, **kwargs: Any):
        kwargs.setdefault("adapt", False)
        super().__init__(**kwargs)


class PhyPlanPositionAgent(PhyPlanAgent):
    """``phyplan-position``: PhyPlan whose GP-UCB models the landing-position error of the chain (our addition
    beyond the paper: ``residual="position"``) instead of the paper's reward error."""

    name = "phyplan-position"

    def __init__(self, **kwargs: Any):
        kwargs.setdefault("residual", "position")
        super().__init__(**kwargs)


class PhyPlanSimAgent(PhyPlanAgent):
    """``phyplan-sim``: the PhyPlan planner scoring candidates with the real MuJoCo simulator (paper Fig. 9).

    Needs the harness's counted :class:`~phyplan_agents.base.Simulator`; every scored candidate is one simulator
    call. The simulator's reward is exact, so there is no error for a GP to model: ``adapt`` defaults to false.
    """

    name = "phyplan-sim"
    needs_simulator = True

    def __init__(self, **kwargs: Any):
        kwargs.setdefault("scorer", "sim")
        kwargs.setdefault("adapt", False)
        super().__init__(**kwargs)
