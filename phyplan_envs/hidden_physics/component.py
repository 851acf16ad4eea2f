"""The hidden-physics component of an env, held as ``env.hidden`` (its class: the env's class attribute
``hidden_model``): :class:`NoHiddenPhysics` for the nominal tasks, and for the varied tasks
(:mod:`phyplan_envs.tasks.varied`: each its nominal assembly plus one of these, made by :func:`varied`) a
:class:`HiddenPhysics`.

:class:`HiddenPhysics` draws per-context values from the train or test space (:mod:`phyplan_envs.hidden_physics`)
behind a sealed ``physics_token``, redraws goals until reachable, and serves the privileged ``hidden_physics``
accessor and the ``physics`` reset option. :class:`PendulumHidden` (bob mass and bob-object restitution, the attempt
starting at the bob's first touch) and :class:`PuckHidden` (plus table and plank friction, the puck on its launch
pad) are the parts the pendulum tasks share; each task's own (reach band, goal range; Bounce's ball-incline
restitution) is in :mod:`phyplan_envs.hidden_physics.tasks`.

The env calls the component from one place each (:class:`NoHiddenPhysics` does the nominal thing): ``adapt(tools)``
(it takes over parts of the assembly) and ``build(root)`` (its contacts) while building; ``take_options``,
``sample_context``, ``check_context_entry`` and ``reset_scene(context, reset_tools)`` at a reset;
``after_apply(action)`` at the end of the kinematic set-up, and in robot mode ``before_arm(action)`` and
``after_arm(action)`` around the arm's set-up.
"""
from __future__ import annotations

import math
from typing import Any, Mapping

import mujoco
import numpy as np

from ..spaces import _process_secret, short_repr
from ..end_rule import chunk_for
from . import contacts as hc
from . import declaration as hp

TIMESTEP = 0.0005          # s (the nominal tasks: 0.001)
REACH_MARGIN = 0.03        # the reach band is shrunk by this fraction at each end before goals are drawn
MIN_GOAL_BAND = 0.03       # m: narrower overlaps of reach band and goal region redraw the physics
TOUCH_OVERLAP = 1e-9       # m: the bodies start this far inside each other, so the contact is active at step 1
SETTLE_TIME = 0.3          # s: the object settles on its support before the first touch (as during a swing)
ON_PAD = np.array([0.0, 0.0, hc.PAD_RISE])     # the puck's start on its launch pad, above the nominal start


def varied(name: str, module: str, nominal: type, hidden: type, doc: str, **attrs: Any) -> type:
    """The varied task class ``name`` (of module ``module``, documented by ``doc``): ``nominal``'s assembly plus the
    hidden-physics component ``hidden``, its timestep :data:`TIMESTEP`; ``hidden.varied_attributes(nominal)`` (the
    nominal facts the hidden physics changes) and ``attrs`` set the rest. A subclass of ``nominal`` that only sets
    class attributes: its methods are the nominal task's."""
    body = {"__module__": module, "__qualname__": name, "__doc__": doc, "task_name": hp.varied_name(nominal.task_name),
            "base_task": nominal.task_name, "hidden_model": hidden, "timestep": TIMESTEP,
            "object_geom": f"{nominal.object_name}_geom", **hidden.varied_attributes(nominal), **attrs}
    return type(name, (nominal,), body)


class NoHiddenPhysics:
    """The nominal tasks' physics: nothing hidden (the context is the goal); every call does the nominal thing."""

    context_keys: tuple[str, ...] = ()
    reset_options: tuple[str, ...] = ()
    override = None

    def __init__(self, env, physics_space=None):
        if physics_space is not None:
            raise TypeError(f"{type(env).__name__} has no hidden physics: physics_space is an argument of the "
                            "varied tasks")
        self.env = env

    def values(self) -> dict[str, float]:
        raise AttributeError(f"{type(self.env).__name__} has no hidden physics")

    @property
    def parameters(self) -> tuple:
        raise AttributeError(f"{type(self.env).__name__} has no hidden physics")

    def adapt(self, tools) -> None:
        """Take over parts of the nominal assembly before it is built; default none."""

    def build(self, root) -> None:
        """Add the component's contacts to the scene; default none."""

    def take_options(self, seed: int | None, options: dict[str, Any]) -> None:
        """Pop the component's reset options; default none."""

    def check_context_entry(self, name: str, value: Any) -> Any:
        raise ValueError(f"{self.env.task_name}: options['context'][{name!r}] has no check; a task that adds a "
                         "context entry declares it in context_keys and checks it in check_context_entry")

    def sample_context(self, rng: np.random.Generator) -> dict[str, Any]:
        return {"goal": self.env.sample_goal(rng)}

    def reset_scene(self, context, reset_tools) -> None:
        reset_tools()

    def after_apply(self, action) -> None:
        """The kinematic set-up is done (the tools placed for ``action``); default nothing."""

    def before_arm(self, action) -> None:
        """Robot mode: the scene before the arm moves; default nothing."""

    def after_arm(self, action) -> None:
        """Robot mode: the arm has let go (its set-up succeeded); default nothing."""

    def stepper(self):
        """The physics step of the flight (``step(model, data, nstep)``); default ``mujoco.mj_step``."""
        return mujoco.mj_step

    def describe(self, description, actions) -> None:
        """Mark in the scene description (:mod:`phyplan_envs.description`) what the component hides or adds;
        default nothing."""


class HiddenPhysics(NoHiddenPhysics):
    """Hidden physics of the varied env ``env`` (its ``base_task`` names the parameters).

    Args (of the env, besides the nominal task's):
        physics_space: ``"auto"`` (default: ``reset(seed=s)`` with s in the test split draws from the test space,
            other seeds from the train space; an unseeded reset keeps the last seeded reset's space), ``"train"`` or
            ``"test"``.

    Reset options (besides the nominal ones): ``physics``: a dict of all hidden values to use instead of the
    context's (privileged: data generation and analysis; the harness never passes it).

    The context is ``{"goal", "physics_token"}``: the token seals the context's physics key and space under the
    secret the env took from its process at construction (:data:`phyplan_envs.spaces.SECRET_ENV`), so only an env
    holding that secret replays it (in this process or a child that inherited the variable; any other raises).
    """

    context_keys = ("physics_token",)
    reset_options = ("physics",)
    goal_distance_range: tuple[float, float] = (0.0, math.inf)
    reach_margin: float = REACH_MARGIN       # a component's own, where its reach band is measured, not closed-form
    min_goal_band: float = MIN_GOAL_BAND

    @classmethod
    def varied_attributes(cls, nominal: type) -> dict[str, Any]:
        """The class attributes of the nominal task ``nominal`` that this hidden physics changes; default none."""
        return {}

    def __init__(self, env, physics_space: str | None = None):
        physics_space = "auto" if physics_space is None else physics_space
        if not isinstance(physics_space, str):
            raise TypeError(f"physics_space must be 'auto', 'train' or 'test', got {type(physics_space).__name__} "
                            f"{short_repr(physics_space)}")
        if physics_space != "auto":
            hp.check_space(physics_space)
        super().__init__(env)
        self.base_task = env.base_task
        self.physics_space = env.physics_space = physics_space
        self._seed_space = "train"
        self._hidden: dict[str, float] | None = None
        self.override: dict[str, float] | None = None     # this reset's ``physics`` option
        self._physics_secret = _process_secret()
        env.chunk = chunk_for(env.timestep)   # end-rule checks every 5 ms, as the nominal tasks

    # --- privileged --------------------------------------------------------------------------------------------
    def values(self) -> dict[str, float]:
        """The current context's hidden values: the one privileged accessor, for the harness's reports, diagnostics,
        design checks and tests, never for an agent (an agent in this process can read it, as any memory: the
        guarantee is that the context, the observation, ``info`` and the public functions do not give it away;
        docs/hidden-physics.md, *Threat model*)."""
        if self._hidden is None:
            raise RuntimeError("call reset() before reading hidden_physics")
        return dict(self._hidden)

    @property
    def parameters(self) -> tuple[hp.HiddenParameter, ...]:
        return hp.parameters(self.base_task)

    # --- the env's calls ---------------------------------------------------------------------------------------
    def take_options(self, seed: int | None, options: dict[str, Any]) -> None:
        """Pop the ``physics`` option of this reset (validated) and note the space of a seeded reset; a context in
        the format before the physics was sealed is refused."""
        old = options.get("context")
        if isinstance(old, Mapping) and ({"physics_key", "physics_space"} & set(old)):
            raise ValueError(f"{self.env.task_name}: options['context'] holds 'physics_key'/'physics_space', the "
                             "context format before the physics was sealed (the key let anyone compute the hidden "
                             "values); contexts now hold 'goal' and 'physics_token': pass back info['context']")
        physics = options.pop("physics", None)
        self.override = hp.check_values(self.base_task, physics) if physics is not None else None
        if seed is not None:
            self._seed_space = hp.space_of_seed(seed)

    def check_context_entry(self, name: str, value: Any) -> Any:
        """A passed-back context's ``physics_token``: sealed for this task under this env's secret, else it raises."""
        if name == "physics_token":
            hp.open_token(self.base_task, value, self._physics_secret)
            return value
        return super().check_context_entry(name, value)

    def sample_context(self, rng: np.random.Generator) -> dict[str, Any]:
        space = self._seed_space if self.physics_space == "auto" else self.physics_space
        for _ in range(1000):
            key = int(rng.integers(0, hp.KEY_BOUND))
            lo, hi = self.reach_band(hp.values_of_key(self.base_task, key, space))
            lo, hi = lo * (1 + self.reach_margin), hi * (1 - self.reach_margin)
            glo, ghi = self.goal_distance_range
            if min(hi, ghi) - max(lo, glo) < self.min_goal_band:
                continue                                 # the physics cannot reach the goal region: redraw it
            while True:
                goal = self.sample_goal(rng)
                if lo <= np.linalg.norm(goal - self.reach_origin) <= hi:
                    return {"goal": goal,
                            "physics_token": hp.seal_token(self.base_task, key, space, self._physics_secret)}
        raise RuntimeError(f"{self.env.task_name}: no reachable goal for 1000 physics draws")

    def reset_scene(self, context, reset_tools) -> None:
        """The context's hidden values set, then the nominal tools' reset (``reset_tools()``)."""
        if self.override is not None:
            values = dict(self.override)
        else:
            if "physics_token" not in context:
                raise ValueError(f"{self.env.task_name}: options['context'] needs its 'physics_token' (pass back the "
                                 f"context of info['context'] unchanged)")
            key, space = hp.open_token(self.base_task, context["physics_token"], self._physics_secret)
            values = hp.values_of_key(self.base_task, key, space)
        self.set_hidden(values)
        self._hidden = values
        reset_tools()

    # --- declared by each task's component ------------------------------------------------------------------------
    def set_hidden(self, values: Mapping[str, float]) -> None:
        raise NotImplementedError(f"{type(self).__name__} must implement set_hidden")

    def reach_band(self, values: Mapping[str, float]) -> tuple[float, float]:
        """(nearest, farthest) distance from ``reach_origin`` that the object can end at under ``values``."""
        raise NotImplementedError(f"{type(self).__name__} must implement reach_band")

    def sample_goal(self, rng: np.random.Generator) -> np.ndarray:
        raise NotImplementedError(f"{type(self).__name__} must implement sample_goal")
