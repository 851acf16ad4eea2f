"""The chain composer: a task's skill chain composed, by events, from the scene description the task publishes.

No chain is written per task. For a batch of actions the composer asks the task for its scene
(``env.describe(actions)``, :mod:`phyplan_envs.description`: the moving object, the pendulum that strikes it or the
point it is let go from, the support tops, the faces, the landing height) and runs the moving object through the
scene with the learnt skills, one event at a time:

* **start**: a :class:`~phyplan_envs.description.Striker` swings (``swing``: the bob's speed at the bottom of its
  arc) and hits the object (``hit``: its launch speed along the swing plane); a
  :class:`~phyplan_envs.description.Release` lets it fall from rest;
* **on a support**: a frictional top -> ``slide`` until the path's centre passes the top's edge (or the object
  stops: the end); a frictionless pad over a frictional top -> crossed at constant speed; a frictionless top with
  nothing under its edge (the pedestal) -> the object flies from where it was hit (the ``hit`` skill's speed is the
  outcome-equivalent launch speed from the resting position, exact at the landing height); where the flight can
  meet a face, a ball flies instead from its physical state after the hit (:mod:`.hand_over`: ``hit_free``, or
  ``hit_free_slow`` for slow hits and Paddles' push; ``hit_free_cond`` under a hidden restitution; where the skill
  set has them: height and velocity 0.115 m, or 0.075 m for slow hits, out along the swing). At an edge,
  a top at most :data:`STEP_DOWN` lower that holds the path (a plank beside a table) takes the object over at its
  speed, else it flies;
* **in flight**: ``throw`` until the first of: the centre falls through the landing height (the end), or it comes
  within the object's radius of a face's plane inside the face's polygon -> a bounce skill hands over the outgoing
  velocity and the flight goes on. The bounce skill is the most specific one whose domain holds the arrival:
  ``bounce`` (``bounce_cond``) for an arrival in the vertical plane of the face's downslope (a drop onto the
  wedge), else the general-incidence ``bounce_general`` (``bounce_general_cond``; ``bounce_general_fast`` for
  arrivals faster than its 6 m/s), or ``bounce_wall`` for a steep
  face; where the plane is met just outside the polygon (within the radius), the flight is searched again with
  the face's edges as events (:mod:`~phyplan_agents.phyplan.edge_contact`), and a touch of an edge or a corner
  bounces like a face of the contact's normal;
* **on a face**: a face of restitution 0 keeps the object, and so does any face it meets too slowly for a bounce
  (less than :data:`~phyplan_agents.phyplan.rollout.SETTLE` towards it): the object glides (``glide``: from the
  arrival's velocity along the face) until its centre passes an edge of the face, and flies from there; a face of
  low restitution (below ``bounce_general``'s domain) bounces through ``bounce_general_low``
  (``bounce_general_low_cond``); an exact-impact face (PaddlesVaried-v3's paddles) bounces through
  ``bounce_general_exact_cond`` until a rebound would be slower than the face's ``glide_speed`` or its hop would rise
  less than :data:`~phyplan_agents.phyplan.rollout.SKIP_HOP`, and the object glides from there; a touch within
  :data:`~phyplan_agents.phyplan.rollout.EXACT_EDGE_GUARD` of such a face's edge, where its restitution is at least
  ``edge_guard_from``, has no prediction;
* each skill serves the queries inside its training ranges; a query outside them goes to the skill's wider twin
  where the skills have one (``swing_wide``, ``hit_wide``, ``throw_wide``: e.g. Paddles' gentle pushes and fast
  falls), and a query outside both to its widest (``throw_fast``: balls bouncing off paddles);
* **an obstacle** (:class:`~phyplan_envs.description.Obstacle`: an upright block, e.g. the pedestal's column): a
  flight that touches one (its side, or its top from above) ends there with no prediction, since no skill knows
  that contact; an obstacle the flight starts on (the ball hit off the pedestal) is not met on that flight.
  Obstacles are searched on the flights of scenes with faces: without a face to turn it back, a flight runs
  straight out in the plane from where it starts;
* an arrival outside every skill's domain (a grazing touch, a face that faces down) or a flight that does not
  end within the ``throw`` skill's time range has no prediction: NaN, which the planner scores as the worst reward.
  The pendulum is not an obstacle of a flight: a ball that flies back into its swinging bob is predicted as if it
  were not there.

On a hidden-physics task every row is an action followed by the task's hidden parameters
(:func:`phyplan_envs.hidden_physics.parameter_names`); the description names the parameter behind each contact,
and the composer feeds its value to the conditioned skills (``hit_cond``, ``hit_free_cond``, ``slide_cond``,
``bounce_cond``, ``bounce_general_cond``).

:func:`chain_for` gives a task's chain as a :class:`Chain`, so
:class:`~phyplan_agents.phyplan.predictor.ChainPredictor` scores actions with it unchanged.
"""
from __future__ import annotations

from typing import Any, Callable, Mapping, NamedTuple

import numpy as np
import torch

from phyplan_envs.hidden_physics import is_varied, parameter_names, parameters
from phyplan_envs.skill_scenes import DATA_SPECS
from phyplan_envs.skill_scenes import bounce_general as general_scene

from ..base import check_scene
from .face_bounce import IMPACT_CONTACTS
from .rollout import EXACT_EDGE_GUARD_FROM, STEP_DOWN, Rollout  # noqa: F401  (STEP_DOWN named in the docstring)


class Chain(NamedTuple):
    """One task's skill chain: its name, the skills its events call, and ``rollout(state, rows, skills, facts)``
    (the predicted final xy ``(N, 2)`` of a batch of rows: actions, followed by the physics on a hidden-physics
    task)."""

    task: str
    skills: tuple[str, ...]
    rollout: Callable


class ComposedChain:
    """The composed chain of task ``task`` (any registered task name; ``"<task>-varied"`` for its hidden-physics
    version) made with the scene arguments ``scene`` (the task class's ``scene_args``, e.g. ``{"paddles": 4}``).
    ``skills``: the skills it uses (from the task's scene); :meth:`rollout` is a chain's rollout; ``facts`` the
    scene's physical facts.

    ``env``: compose the chain of this env's scene instead of a new one of the task's registered class: an env of a
    task subclass (a design study's other paddles, or a researcher's own task) whose ``describe`` publishes its
    scene. ``task`` is then the env's ``task_name`` and ``scene`` its scene arguments.

    ``edge_guard_from``: the restitution from which a touch near an exact-impact face's edge has no prediction
    (:data:`~phyplan_agents.phyplan.rollout.EXACT_EDGE_GUARD_FROM`; 0: at every restitution)."""

    def __init__(self, task: str | None = None, scene: Mapping[str, Any] | None = None, env=None,
                 edge_guard_from: float = EXACT_EDGE_GUARD_FROM):
        import phyplan_envs

        self.edge_guard_from = float(edge_guard_from)
        if not (np.isfinite(self.edge_guard_from) and self.edge_guard_from >= 0):
            raise ValueError(f"edge_guard_from must be a restitution >= 0, got {edge_guard_from!r}")

        if env is None:
            cls = phyplan_envs.task_class(task)
            self.scene = check_scene(cls, scene)
            env = cls(with_panda=False, **self.scene)      # describes the scene; never stepped
        else:
            env = env.unwrapped
            if task is not None or scene is not None:
                raise ValueError("give task and scene, or env: the env's task_name and scene arguments are its own")
            if not callable(getattr(env, "describe", None)):
                raise ValueError(f"env {type(env).__name__} publishes no scene: it has no describe(actions)")
            task = env.task_name
            self.scene = {k: getattr(env, k) for k in getattr(env, "scene_args", ())}
        self.task = task
        self.varied = is_varied(task)
        self.params = parameter_names(task) if self.varied else ()
        self.env = env
        self.facts = self.env.facts
        self.action_dim = len(self.env.action_dims)
        low, high = self.env.action_low, self.env.action_high
        hulls = {p.name: p.hull() for p in parameters(task)} if self.varied else {}
        self.skills = needed_skills(self.env.describe(np.stack([low, (low + high) / 2, high])), hulls)

    def rollout(self, state, rows, skills, facts=None) -> torch.Tensor:
        """Predicted final xy ``(N, 2)`` of the moving object for ``rows`` ``(N, A [+ P])`` (module docstring);
        ``state`` and ``facts`` are not needed (the scene says it all) and kept for the chain interface."""
        return self.trace(rows, skills).final.clone()

    def trace(self, rows, skills) -> Rollout:
        """The finished :class:`~phyplan_agents.phyplan.rollout.Rollout` of ``rows`` (as :meth:`rollout`): its
        ``final`` xy and, per row, how many of its contacts were at a face's edge or corner (``edges``)."""
        rows = torch.as_tensor(rows, dtype=torch.float32)
        if rows.ndim != 2 or rows.shape[1] != self.action_dim + len(self.params):
            raise ValueError(f"{self.task}: rows must have shape (N, {self.action_dim + len(self.params)}) "
                             f"(the action{' and the hidden physics' if self.params else ''}), got "
                             f"{tuple(rows.shape)}")
        n = rows.shape[0]
        d = self.env.describe(rows[:, :self.action_dim].double().numpy())
        physics = {name: rows[:, self.action_dim + i] for i, name in enumerate(self.params)}
        with torch.inference_mode():      # the fast skill twins return inference tensors, updated in place here
            r = Rollout(d, skills, physics, n, self.edge_guard_from)
            r.run()
        return r


def needed_skills(d, hulls: Mapping[str, tuple[float, float]] | None = None) -> tuple[str, ...]:
    """The skills a composed chain of scene ``d`` can call, in the order of the events: a striker's swing and hit
    (conditioned when its contact's restitution is given; their wider twins when its releases leave the swing
    skill's domain), the slide on frictional tops (conditioned on a hidden friction) after a hit, the throw, and the
    bounce and glide skills of each face's contact (``hulls``: each hidden parameter's range)."""
    hulls = dict(hulls or {})
    names = []
    if d.striker is not None:
        lo, hi = DATA_SPECS["swing"].ranges[0]
        wide = bool(np.any((np.asarray(d.striker.release) < lo) | (np.asarray(d.striker.release) > hi)))
        names += ["swing", "hit" if d.striker.restitution is None else "hit_cond"]
        names += ["swing_wide", "hit_wide"] if wide else []
        for s in d.supports:
            if s.friction != 0:
                names.append("slide_cond" if isinstance(s.friction, str) else "slide")
    names.append("throw")
    for f in d.faces:
        e = f.restitution
        if f.contact == "exact_impact":
            names += ["bounce_general_exact_cond", "glide"]
        elif f.contact in IMPACT_CONTACTS:
            names += ["bounce_cond", "bounce_general_cond"]
            if isinstance(e, str) and hulls.get(e, (1.0, 1.0))[0] < general_scene.COND_DOMAIN[0]:
                names += ["bounce_general_low_cond", "glide"]
        elif not isinstance(e, str) and float(e) == 0.0:
            names.append("glide")
        elif not isinstance(e, str) and float(e) < general_scene.E_NOMINAL_RANGE[0]:
            names += ["bounce_general_low", "glide"]
        else:
            names += ["bounce", "bounce_general"]
    return tuple(dict.fromkeys(names))


_CHAINS: dict[tuple, ComposedChain] = {}


def composed(task: str, scene: Mapping[str, Any] | None = None) -> ComposedChain:
    """The :class:`ComposedChain` of task ``task`` with scene arguments ``scene`` (built once per process)."""
    import phyplan_envs

    if task not in phyplan_envs.ALL_TASKS:
        raise ValueError(f"task {task!r} has no skill chain: it is not a registered task; tasks: "
                         f"{', '.join(phyplan_envs.ALL_TASKS)}")
    key = (task, tuple(sorted(dict(scene or {}).items())))
    if key not in _CHAINS:
        _CHAINS[key] = ComposedChain(task, scene)
    return _CHAINS[key]


def chain_for(task: str, scene: Mapping[str, Any] | None = None) -> Chain:
    """The composed skill chain of task ``task`` (any registered task name, e.g. ``"launch"``,
    ``"launch-bounce-varied"``) with scene arguments ``scene`` (e.g. ``{"paddles": 4}``; built once per process);
    ``ValueError`` naming the known tasks."""
    c = composed(task, scene)
    return Chain(task, c.skills, c.rollout)
