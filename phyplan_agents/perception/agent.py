"""``phyplan-perception``: the PhyPlan agent planning from the RGB-D observation alone.

It asks for ``obs_mode="rgbd"`` (:attr:`PhyPlanPerceptionAgent.env_kwargs`), reads the state vector the skill chain
needs from the context's picture (:func:`phyplan_agents.perception.perceive`) and then plans exactly as ``phyplan``
(MCTS over the skill chain, GP-UCB on the reward error). It reads nothing from ``info``: neither at
``begin_context`` (the harness's ``info["context"]`` holds the goal) nor after an attempt (the reward residual needs
only the reward).

What it knows besides the pictures: the camera's calibration (a fixed property of the env, read once in
:meth:`~PhyPlanPerceptionAgent.setup` from its own copy of the env, made without the Panda and never stepped or
reset), the task's declared facts, as ``phyplan`` does, and the task's goal distribution (goals drawn from that
copy's ``sample_context`` with a fixed seed: :func:`~phyplan_agents.perception.goal_belief.sampler_prior`).

**When the picture does not show the goal** (hidden under the Bridge plank, cut by the picture's border, a failed
fit) the agent does not give up (docs/perception.md, *When the picture is not enough*): it keeps a belief over goal
centres (:class:`~phyplan_agents.perception.goal_belief.GoalBelief`: the goal distribution times what the picture
allows, times, after each attempt, the Apollonius circle its reward puts the goal on) and aims every attempt at the
plausible goal with the highest expected reward, GP-UCB off. Once 90% of the belief lies within max(2 cm, sigma) of
that aim it plans as ``phyplan`` with it and refits GP-UCB on every attempt against it. A goal the pictures placed
is not moved by chain-predicted landings (their error is systematic near one action: GP-UCB's job); one found from
the rewards alone is polished by least squares on the attempts' circles
(:func:`~phyplan_agents.perception.apollonius.solve_goal`) and keeps being updated. The landing of an attempt is
the skill chain's prediction, or read from the picture after the attempt if the caller passes it
(``observe(..., obs=after)``: the harness does not), which may also show the goal (the plank has moved).
:attr:`fallback` and the counters ``perception_fallback``, ``goal_inferred``, ``goal_seen_again`` say what happened.
A scenery entry that cannot be read is taken from the declared facts of the same name; an entry that is in neither
is still a :class:`~phyplan_agents.perception.PerceptionError`.

On the varied tasks (``<task>-varied``) the scene is read by the nominal task's reader and the planner is
``phyplan``'s there (the conditioned chain at the nominal physics); ``phyplan-perception-sysid``
(:mod:`.sysid`) adds the identification of the hidden physics.
"""
from __future__ import annotations

from typing import Any, Mapping

import numpy as np

from phyplan_envs.hidden_physics import base_task

from ..base import Agent, TaskInfo
from ..phyplan.agent import PhyPlanAgent
from .apollonius import solve_goal
from .goal_belief import CONFIDENT, MASS, GoalBelief, landing_of, sampler_prior
from .reads import RGBDView, read_goal
from .scene import Percept, perceive

IMAGE_SIZE = 256     # pixels: at 128 the goal's centre errs ~2x more (1 pixel is ~8 mm on the ground at 256)
GOAL = ("goal_x", "goal_y")
# The landing's error in the goal belief's update, per task (m): about the skill chain's p90 error over random
# actions (docs/phyplan.md, "Skill chain vs simulator": Launch 7.6 mm, Slide 10, Bounce 11.6, Bridge 37; the update's
# truncation at 4 sigma takes care of the worst landings)
LANDING_SIGMA = {"launch": 0.01, "slide": 0.01, "bounce": 0.01, "bridge": 0.025}
PICTURE_SIGMA = 0.005   # m: a landing read from the picture after the attempt (the readers' ~1-3 mm, with margin)


def camera_calibration(task: TaskInfo, name: str = "obs"):
    """The calibration of camera ``name`` of the env ``task`` describes, and the env's facts and state names.

    Read from a private copy of the env (no Panda; it is never reset or stepped, so it knows no context)."""
    return scene_knowledge(task, name, prior_samples=0)[:3]


def scene_knowledge(task: TaskInfo, name: str = "obs", prior_samples: int = 20000):
    """:func:`camera_calibration` plus the task's goal distribution on a grid (``(grid, density)``, or ``None``
    with ``prior_samples=0``), all from one private copy of the env."""
    import phyplan_envs

    size = int(dict(task.env_kwargs).get("image_size", 128))
    env = phyplan_envs.task_class(task.task)(image_size=size, with_panda=False)
    try:
        prior = sampler_prior(env, samples=prior_samples, seed=0) if prior_samples > 0 else None
        return env.camera_model(name), env.facts, tuple(env.state_names), prior
    finally:
        env.close()


def _from_facts(names, state: np.ndarray, facts) -> list[str]:
    """Fill unmeasured scenery entries from the declared facts of the same name (object start: ``*_start``);
    returns the names filled."""
    filled = []
    start = next((getattr(facts, a) for a in ("puck_start", "ball_start") if hasattr(facts, a)), None)
    for k, n in enumerate(names):
        if n in GOAL or np.isfinite(state[k]):
            continue
        if n.startswith("object_") and start is not None:
            state[k] = float(start["xyz".index(n[-1])])
        elif isinstance(getattr(facts, n, None), (int, float)):
            state[k] = float(getattr(facts, n))
        else:
            continue
        filled.append(n)
    return filled


class PhyPlanPerceptionAgent(PhyPlanAgent):
    """PhyPlan from RGB-D pictures: :func:`~phyplan_agents.perception.perceive`, then the ``phyplan`` planner.

    Args:
        landing_sigma: the error of an attempt's landing in the goal belief's update (m; default per task,
            :data:`LANDING_SIGMA`).
        prior_samples: goals drawn for the task's goal distribution (default 20000).
        goal_from_picture: false: an ablation that ignores the goal in every picture (neither the goal reader nor
            the carving), so that the goal comes from the task's goal distribution and the rewards alone.
        **kwargs: every option of :class:`~phyplan_agents.phyplan.agent.PhyPlanAgent`.

    After ``begin_context``, :attr:`percept` holds what was read (state, per-object measurements), :attr:`belief`
    the goal belief (``None`` when the goal was seen) and :attr:`goal_estimate` the goal the planner uses.
    """

    name = "phyplan-perception"
    env_kwargs = {"obs_mode": "rgbd", "image_size": IMAGE_SIZE}

    def __init__(self, landing_sigma: float | None = None, prior_samples: int = 20000, goal_from_picture: bool = True,
                 **kwargs: Any):
        if kwargs.get("residual", "reward") != "reward":
            raise ValueError("phyplan-perception models the reward error only: residual='position' reads the final "
                             "position from the step's info, which this agent does not use")
        if kwargs.get("scorer", "chain") != "chain":
            raise ValueError("phyplan-perception plans with the skill chain (scorer='chain'); the simulator scorer "
                             "would need the state")
        if (landing_sigma is not None and landing_sigma <= 0) or int(prior_samples) < 100:
            raise ValueError(f"landing_sigma must be positive and prior_samples >= 100, got {landing_sigma}, "
                             f"{prior_samples}")
        super().__init__(**kwargs)
        self.landing_sigma = None if landing_sigma is None else float(landing_sigma)
        self.prior_samples = int(prior_samples)
        self.goal_from_picture = bool(goal_from_picture)
        self.percept: Percept | None = None
        self.belief: GoalBelief | None = None
        self.fallback: dict[str, Any] = {}
        self._camera = None

    def setup(self, task: TaskInfo, seed: int = 0) -> None:
        if task.obs_mode != "rgbd":
            raise ValueError(f"{self.name} plans from RGB-D pictures; make the env with obs_mode='rgbd' "
                             f"(got obs_mode={task.obs_mode!r})")
        super().setup(task, seed)
        for key in ("perception_fallback", "goal_inferred", "goal_seen_again"):
            self._counters.setdefault(key, 0)
        self._camera, self._facts, self._state_names, prior = scene_knowledge(task, prior_samples=self.prior_samples)
        self._grid, self._density = prior
        self._reader = base_task(task.task)
        self._sigma = self.landing_sigma or LANDING_SIGMA.get(self._reader, 0.02)

    # -- the context's picture --------------------------------------------------------------------------------------
    def read_state(self, obs: Any) -> np.ndarray:
        """The state vector read from the picture; an unseen goal becomes the goal belief's aim (module docstring).
        :class:`~phyplan_agents.perception.PerceptionError` only for a scenery entry neither seen nor declared."""
        if self._camera is None:
            raise RuntimeError("setup(task, seed) must be called before begin_context()")
        self.percept = p = perceive(self._reader, obs, self._camera, self._facts, self._state_names)
        if not self.goal_from_picture:
            p.state[[self._state_names.index(n) for n in GOAL]] = np.nan
            p.problems.append("goal: not read (goal_from_picture=False)")
        self.belief, self.fallback, self._landings, self._source = None, {}, [], None
        if p.ok:
            self.goal_known = True
            return p.state.copy()
        state = p.state.copy()
        filled = _from_facts(self._state_names, state, self._facts)
        idx = [self._state_names.index(n) for n in GOAL]
        if not np.all(np.isfinite(np.delete(state, idx))):
            p.require()                                       # raises, naming what is missing
        if filled:
            self.count("scenery_from_facts", len(filled))
        self.fallback = {"problems": list(p.problems), "from_facts": filled}
        if np.all(np.isfinite(state[idx])):
            self.goal_known = True
            return state
        self.count("perception_fallback")
        if self.goal_from_picture:
            self.belief, notes = GoalBelief.from_view(RGBDView(obs, self._camera), self._grid, self._density,
                                                      state[2:4], self._sigma)
        else:
            self.belief, notes = GoalBelief(self._grid, self._density, state[2:4], self._sigma), {}
        self._radius = max(CONFIDENT, self._sigma)
        target, mass = self.belief.aim(self._radius)
        state[idx] = target
        self.goal_known = mass >= MASS
        self._source = "picture" if self.goal_known else None
        self.fallback.update(notes, found_after=0 if self.goal_known else None, aims=[], source=self._source)
        if self.goal_known:
            self.count("goal_inferred")
        return state

    @property
    def goal_estimate(self) -> np.ndarray:
        """The goal the planner aims at (the seen one, or the belief's)."""
        return np.asarray(self.state[:2], dtype=np.float64).copy()

    def _set_goal(self, goal: np.ndarray) -> None:
        self.state = self.state.copy()
        self.state[:2] = goal
        self.predictor.set_context(self.state)

    # -- attempts ---------------------------------------------------------------------------------------------------
    def act(self) -> np.ndarray:
        if self.belief is not None and not self.goal_known:
            target, _ = self.belief.aim(self._radius)
            self._set_goal(target)
            self.fallback["aims"].append(target.tolist())
        return super().act()

    def observe(self, action: np.ndarray, reward: float, info: Mapping[str, Any], obs: Any = None) -> None:
        """The attempt's outcome. ``obs``: the picture after the attempt, if the caller has it (the harness does not
        pass it); it is read only while the goal is unseen at reset."""
        if self.belief is None:
            super().observe(action, reward, info)
            return
        Agent.observe(self, action, reward, info)
        a = np.asarray(action, dtype=np.float64)
        if obs is not None and self.goal_from_picture:
            goal, _ = read_goal(RGBDView(obs, self._camera))
            if goal is not None:
                self.belief.seen(goal)
                self._source = "picture"
                self.count("goal_seen_again")
        landing = landing_of(obs, self._camera, self._facts, self._reader)
        if landing is not None:                       # seen: true coordinates, as the pictures' goal evidence
            self.belief.update(landing, reward, sigma=PICTURE_SIGMA)
        elif self._source != "picture":
            # the chain's landing: its error is systematic near one action, so it is not mixed with a goal the
            # pictures placed (GP-UCB corrects it there); without one, the goal is found where the chain must aim
            self.count("skill_evals", 1)
            landing = self.predictor.final_xy(a[None])[0]
            self.belief.update(landing, reward)
        self._landings.append(np.full(2, np.nan) if landing is None else landing)
        target, mass = self.belief.aim(self._radius)
        if self._source is None and mass < MASS:
            self.goal_known = False
            self.gp.reset()
            return
        if not self.goal_known:
            self.count("goal_inferred")
            self.fallback["found_after"] = len(self.history)
        self.goal_known = True
        self._source = self._source or "rewards"
        goal = target
        if self._source == "rewards":
            fit = solve_goal(self.state[2:4], np.array(self._landings), [h[1] for h in self.history], target)
            if fit.determined and np.linalg.norm(fit.goal - target) <= self._radius:
                goal = fit.goal
        self._set_goal(goal)
        self.fallback.update(goal=goal.tolist(), source=self._source)
        if self.adapt:
            actions = np.vstack([h[0] for h in self.history])
            residuals = np.array([h[1] for h in self.history]) - self.predicted_reward(actions)
            keep = np.isfinite(residuals)
            if keep.any():
                self.gp.set_data(actions[keep], residuals[keep])
            else:
                self.gp.reset()
