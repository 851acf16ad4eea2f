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
  outcome-equivalent launch speed from the resting position). At an edge, a top at most :data:`STEP_DOWN` lower
  that holds the path (a plank beside a table) takes the object over at its speed, else it flies;
* **in flight**: ``throw`` until the first of: the centre falls through the landing height (the end), or it comes
  within the object's radius of a face's plane inside the face's polygon -> a bounce skill hands over the outgoing
  velocity and the flight goes on. The bounce skill is the most specific one whose domain holds the arrival:
  ``bounce`` (``bounce_cond``) for an arrival in the vertical plane of the face's downslope (a drop onto the
  wedge), else the general-incidence ``bounce_general`` (``bounce_general_cond``);
* an arrival outside every skill's domain (a vertical wall, a grazing touch) or a flight that does not end within
  the ``throw`` skill's time range has no prediction: NaN, which the planner scores as the worst reward.

On a hidden-physics task every row is an action followed by the task's hidden parameters
(:func:`phyplan_envs.hidden_physics.parameter_names`); the description names the parameter behind each contact,
and the composer feeds its value to the conditioned skills (``hit_cond``, ``slide_cond``, ``bounce_cond``,
``bounce_general_cond``).

:func:`chain_for` gives a task's chain as a :class:`Chain`, so
:class:`~phyplan_agents.phyplan.predictor.ChainPredictor` scores actions with it unchanged.
"""
from __future__ import annotations

import math
from typing import Callable, NamedTuple

import numpy as np
import torch

from phyplan_envs.hidden_physics import is_varied, parameter_names
from phyplan_envs.skill_scenes.bounce_cond import ideal_bounce
from phyplan_envs.skill_scenes.hit_cond import ideal_hit_speed

from . import geometry as geo
from . import queries as q

STEP_DOWN = 0.01       # m: an edge hands the object over to a top at most this much lower that holds its path
ON_TOP = 0.002         # m: the object rests on a top whose height is within this of its bottom
MAX_EVENTS = 8         # support crossings and bounces per rollout (a path with more has no prediction)
ACROSS_TOL = 1e-3      # m/s: an arrival with less speed across the face's downslope plane is "in the plane"
_TOL = 1e-6

SUPPORT, FLYING, DONE = 0, 1, 2


class Chain(NamedTuple):
    """One task's skill chain: its name, the skills its events call, and ``rollout(state, rows, skills, facts)``
    (the predicted final xy ``(N, 2)`` of a batch of rows: actions, followed by the physics on a hidden-physics
    task)."""

    task: str
    skills: tuple[str, ...]
    rollout: Callable


class ComposedChain:
    """The composed chain of task ``task`` (any registered task name; ``"<task>-varied"`` for its hidden-physics
    version). ``skills``: the skills it uses (from the task's scene); :meth:`rollout` is a chain's rollout."""

    def __init__(self, task: str):
        import phyplan_envs

        cls = phyplan_envs.task_class(task)
        self.task = task
        self.varied = is_varied(task)
        self.params = parameter_names(task) if self.varied else ()
        self.env = cls(with_panda=False)      # describes the scene; never stepped
        self.action_dim = len(cls.action_dims)
        low, high = self.env.action_low, self.env.action_high
        self.skills = needed_skills(self.env.describe((low + high) / 2))

    def rollout(self, state, rows, skills, facts=None) -> torch.Tensor:
        """Predicted final xy ``(N, 2)`` of the moving object for ``rows`` ``(N, A [+ P])`` (module docstring);
        ``state`` and ``facts`` are not needed (the scene says it all) and kept for the chain interface."""
        rows = torch.as_tensor(rows, dtype=torch.float32)
        if rows.ndim != 2 or rows.shape[1] != self.action_dim + len(self.params):
            raise ValueError(f"{self.task}: rows must have shape (N, {self.action_dim + len(self.params)}) "
                             f"(the action{' and the hidden physics' if self.params else ''}), got "
                             f"{tuple(rows.shape)}")
        n = rows.shape[0]
        d = self.env.describe(rows[:, :self.action_dim].double().numpy())
        physics = {name: rows[:, self.action_dim + i] for i, name in enumerate(self.params)}
        with torch.inference_mode():      # the fast skill twins return inference tensors, updated in place here
            return Rollout(d, skills, physics, n).run().clone()


class Rollout:
    """One batch through the scene: per row the object's position, direction, speeds and phase."""

    def __init__(self, d, skills, physics, n: int):
        self.d, self.skills, self.physics, self.n = d, skills, physics, n
        self.obj = d.object
        self.pos = geo.rows(d.object.start, n, 3).clone()
        self.u = torch.zeros(n, 2)
        self.u[:, 0] = 1.0
        self.vh = torch.zeros(n)
        self.vz = torch.zeros(n)
        self.phase = torch.full((n,), FLYING, dtype=torch.long)
        self.support = torch.full((n,), -1, dtype=torch.long)
        self.final = torch.full((n, 2), float("nan"))
        self.faces = [geo.face_arrays(f, n) for f in d.faces]

    def value(self, v) -> torch.Tensor:
        """A description value per row: a fact, or the row's value of the hidden parameter it names."""
        if isinstance(v, str):
            return self.physics[v]
        return torch.full((self.n,), float(v))

    # --- the start --------------------------------------------------------------------------------------------------
    def start(self) -> None:
        d, n = self.d, self.n
        if d.release is not None:
            self.pos = geo.rows(d.release.pos, n, 3).clone()
            return
        s = d.striker
        plane = geo.rows(s.plane, n)
        self.u = torch.stack([torch.cos(plane), torch.sin(plane)], dim=1)
        v_bob = q.swing_bottom_speed(self.skills.swing, geo.rows(s.release, n), s.length)
        under = self.support_under(self.pos, torch.ones(n, dtype=torch.bool))
        friction = torch.zeros(n)
        for j, sup in enumerate(d.supports):       # the hit's friction: the first frictional top under the object
            if sup.friction != 0:
                friction = torch.where(geo.contains(sup, self.pos[:, :2]) & (friction == 0), self.value(sup.friction),
                                       friction)
        if s.restitution is not None:           # a contact of given restitution: the conditioned hit
            m1, e = self.value(s.bob_mass), self.value(s.restitution)
            m2 = torch.full((n,), float(self.obj.mass))
            gain = q._predict(self.skills.hit_cond, torch.stack([m1, m2, e, friction, v_bob], dim=1))[:, 0]
            self.vh = gain * ideal_hit_speed(m1, m2, e, v_bob)
        else:
            self.vh = q.hit_speed(self.skills.hit, float(s.bob_mass), float(self.obj.mass), v_bob)
        self.support = under
        self.phase = torch.where(under >= 0, SUPPORT, FLYING)

    def support_under(self, pos: torch.Tensor, rows: torch.Tensor, below: float = ON_TOP,
                      exclude: torch.Tensor | None = None) -> torch.Tensor:
        """The index of the highest top under each row's object (its bottom within ``below`` above the top, none:
        -1), among the rows ``rows``; ``exclude`` (N,) a support index per row to skip."""
        bottom = pos[:, 2] - self.obj.half_height
        best = torch.full((self.n,), -1, dtype=torch.long)
        best_top = torch.full((self.n,), -math.inf)
        for j, sup in enumerate(self.d.supports):
            ok = rows & geo.contains(sup, pos[:, :2]) & (bottom - sup.top >= -ON_TOP) & (bottom - sup.top <= below)
            if exclude is not None:
                ok &= exclude != j
            better = ok & (sup.top > best_top)
            best = torch.where(better, j, best)
            best_top = torch.where(better, torch.full_like(best_top, sup.top), best_top)
        return best

    # --- on a support -------------------------------------------------------------------------------------------
    def move_on_supports(self) -> None:
        for j, sup in enumerate(self.d.supports):
            rows = (self.phase == SUPPORT) & (self.support == j)
            if not rows.any():
                continue
            idx = rows.nonzero()[:, 0]
            edge = geo.exit_distance(sup, self.pos[idx, :2], self.u[idx], idx)
            if sup.friction == 0:
                self.cross_frictionless(j, idx, edge)
            else:
                self.slide(j, sup, idx, edge)

    def cross_frictionless(self, j: int, idx: torch.Tensor, edge: torch.Tensor) -> None:
        """A frictionless top: a pad over another top is crossed at constant speed; from any other (the pedestal)
        the object flies from where it was hit."""
        rows = torch.zeros(self.n, dtype=torch.bool)
        rows[idx] = True
        lower = self.support_under(self.pos, rows, below=STEP_DOWN, exclude=torch.full((self.n,), j))
        pad = idx[lower[idx] >= 0]
        self.pos[pad, :2] += edge[lower[idx] >= 0, None] * self.u[pad]
        self.pos[pad, 2] = torch.tensor([self.d.supports[k].top for k in lower[pad].tolist()]) + self.obj.half_height
        self.support[pad] = lower[pad]
        fly = idx[lower[idx] < 0]
        self.phase[fly] = FLYING

    def slide(self, j: int, sup, idx: torch.Tensor, edge: torch.Tensor) -> None:
        if isinstance(sup.friction, str):       # a hidden friction: the friction-conditioned slide
            mu = self.value(sup.friction)[idx]
            ev = q.slide_until(self.skills.slide_cond, self.vh[idx], edge, condition=mu[:, None])
        else:
            ev = q.slide_until(self.skills.slide, self.vh[idx], edge)
        stopped = idx[~ev.valid]
        self.final[stopped] = self.pos[stopped, :2] + ev.y[~ev.valid, 0, None] * self.u[stopped]
        self.phase[stopped] = DONE
        go = idx[ev.valid]
        self.pos[go, :2] += edge[ev.valid, None] * self.u[go]
        self.vh[go] = ev.y[ev.valid, 1].clamp(min=0.0)
        # handed over to a lower top that holds the path just past the edge, else it flies from the edge
        ahead = self.pos.clone()
        ahead[:, :2] += 1e-3 * self.u
        rows = torch.zeros(self.n, dtype=torch.bool)
        rows[go] = True
        nxt = torch.full((self.n,), -1, dtype=torch.long)
        for k, other in enumerate(self.d.supports):
            if k == j or not (sup.top - STEP_DOWN <= other.top <= sup.top + _TOL):
                continue
            nxt = torch.where(rows & (nxt < 0) & geo.contains(other, ahead[:, :2]), k, nxt)
        over = go[nxt[go] >= 0]
        self.support[over] = nxt[over]
        self.pos[over, 2] = torch.tensor([self.d.supports[k].top for k in nxt[over].tolist()]) + self.obj.half_height
        off = go[nxt[go] < 0]
        self.phase[off] = FLYING
        self.vz[off] = 0.0

    # --- in flight ------------------------------------------------------------------------------------------------
    def fly(self) -> None:
        idx = (self.phase == FLYING).nonzero()[:, 0]
        if len(idx) == 0:
            return
        throw = self.skills.throw
        t0, t1 = q.time_range(throw, q.THROW_T_MAX)
        pos, u, vh, vz = self.pos[idx], self.u[idx], self.vh[idx], self.vz[idx]
        if not self.faces:                      # only the ground: the one-crossing query (distinct rows once)
            ev = q.throw_landing(throw, vh, vz, pos[:, 2] - self.d.landing_height)
            land = pos[:, :2] + ev.y[:, 0, None] * u
            self.final[idx] = torch.where(ev.valid[:, None], land, torch.full_like(land, float("nan")))
            self.phase[idx] = DONE
            return
        r = self.obj.radius
        faces = [(v[idx], nrm[idx]) for v, nrm in self.faces]
        u3 = torch.cat([u, torch.zeros(len(idx), 1)], dim=1)
        up = torch.tensor([0.0, 0.0, 1.0])

        def where(y, i):
            return pos[i] + y[:, 0:1] * u3[i] + y[:, 1:2] * up

        def measure(y, t, i):
            p = where(y, i)
            cols = [p[:, 2] - self.d.landing_height]
            cols += [geo.plane_distance(v[i], nrm[i], p) - r for v, nrm in faces]
            return torch.stack(cols, dim=1)

        t_ev, crossed = q.first_events(throw, torch.stack([vh, vz], dim=1), measure, t0, t1)
        m = t_ev.shape[1]
        at = torch.cat([torch.stack([vh, vz], dim=1).repeat_interleave(m, 0), t_ev.reshape(-1, 1)], dim=1)
        y = q._predict(throw, at).reshape(len(idx), m, -1)
        rows_i = torch.arange(len(idx))
        ok = crossed.clone()
        edge = torch.zeros_like(ok)
        for f, (v, nrm) in enumerate(faces):
            p = where(y[:, f + 1], rows_i)
            inside = geo.inside_polygon(v, nrm, p - r * nrm)
            edge[:, f + 1] = ok[:, f + 1] & ~inside & geo.inside_polygon(v, nrm, p - r * nrm, margin=r)
            ok[:, f + 1] &= inside | edge[:, f + 1]
        t_ok = torch.where(ok, t_ev, torch.full_like(t_ev, math.inf))
        first = t_ok.argmin(dim=1)
        none = ~ok.any(dim=1)
        y_first = y[rows_i, first]
        p_first = where(y_first, rows_i)
        ground = (first == 0) & ~none
        self.final[idx[ground]] = p_first[ground, :2]
        # a touch of a face's edge or corner: no skill knows it, so no prediction (NaN)
        at_edge = edge[rows_i, first] & ~none
        self.phase[idx[ground | none | at_edge]] = DONE
        none |= at_edge
        for f in range(len(faces)):
            hit = (first == f + 1) & ~none
            if not hit.any():
                continue
            v_in = vh[hit, None] * u3[hit] + y_first[hit, 2:3] * up
            out = self.bounce(self.d.faces[f], v_in, faces[f][1][hit], idx[hit])
            self.pos[idx[hit]] = p_first[hit]
            horiz = out[:, :2]
            speed = horiz.norm(dim=1)
            self.u[idx[hit]] = torch.where(speed[:, None] > 1e-9, horiz / speed.clamp(min=1e-9)[:, None],
                                           u[hit])
            self.vh[idx[hit]] = speed
            self.vz[idx[hit]] = out[:, 2]
            bad = idx[hit][~torch.isfinite(out).all(dim=1)]
            self.phase[bad] = DONE                 # outside every bounce skill's domain: no prediction (NaN)

    def bounce(self, face, v_in: torch.Tensor, normal: torch.Tensor, idx: torch.Tensor) -> torch.Tensor:
        """Outgoing world velocities (R, 3) of arrivals ``v_in`` at a face (NaN where no skill's domain holds)."""
        from phyplan_agents.skills.bounce_general import GeneralBounce, incline_frame

        e = self.value(face.restitution)[idx]
        out = torch.full_like(v_in, float("nan"))
        if (normal[:, 2].abs() > 1 - 1e-6).any():
            return out                             # a horizontal face: not a bounce the skills know
        frame = incline_frame(normal.double()).float()          # rows: down, across, normal
        angle = torch.arccos(normal[:, 2].clamp(-1.0, 1.0))
        down_h = frame[:, 0, :2] / frame[:, 0, :2].norm(dim=1, keepdim=True).clamp(min=1e-9)
        across_h = torch.stack([-down_h[:, 1], down_h[:, 0]], dim=1)
        v_hor = (v_in[:, :2] * down_h).sum(dim=1)
        v_across = (v_in[:, :2] * across_h).sum(dim=1)
        cond = face.contact == "impact_pair"     # a calibrated pair of any restitution: the conditioned skills
        vertical = self.skills.bounce_cond if cond else self.skills.bounce
        x = torch.stack([e, angle, v_in[:, 2], v_hor], dim=1)
        planar = (v_across.abs() < ACROSS_TOL) & in_ranges(vertical, x)
        if planar.any():
            pv = q._predict(vertical, x[planar])
            if cond:
                iv, ih = ideal_bounce(x[planar, 0], x[planar, 1], x[planar, 2], x[planar, 3])
                pv = torch.stack([iv + pv[:, 0], ih + pv[:, 1]], dim=1)
            out[planar] = torch.cat([pv[:, 1:2] * down_h[planar], pv[:, 0:1]], dim=1)
        general = GeneralBounce(self.skills.bounce_general_cond if cond else self.skills.bounce_general)
        rest = ~planar
        if rest.any():
            ok = torch.zeros_like(rest)
            ok[rest] = general.in_domain(v_in[rest].double(), normal[rest].double(), e[rest].double())
            if ok.any():
                out[ok] = general.predict(v_in[ok].double(), normal[ok].double(), e[ok].double()).float()
        return out

    def run(self) -> torch.Tensor:
        self.start()
        for _ in range(MAX_EVENTS):
            if not (self.phase != DONE).any():
                break
            self.move_on_supports()
            self.fly()
        return self.final


def in_ranges(model, x: torch.Tensor) -> torch.Tensor:
    """Rows of ``x`` inside a skill model's training ranges (its spec), all inputs but none of time."""
    spec = getattr(model, "spec", None)
    if spec is None:
        return torch.ones(x.shape[0], dtype=torch.bool)
    ok = torch.ones(x.shape[0], dtype=torch.bool)
    for k, (lo, hi) in enumerate(spec.ranges[:x.shape[1]]):
        ok &= (x[:, k] >= lo - _TOL) & (x[:, k] <= hi + _TOL)
    return ok


def needed_skills(d) -> tuple[str, ...]:
    """The skills a composed chain of scene ``d`` can call, in the order of the events: a striker's swing and hit
    (conditioned when its contact's restitution is given), the slide on frictional tops (conditioned on a hidden
    friction) after a hit, the throw, and the bounce skills of each face's contact model."""
    names = []
    if d.striker is not None:
        names += ["swing", "hit" if d.striker.restitution is None else "hit_cond"]
        for s in d.supports:
            if s.friction != 0:
                names.append("slide_cond" if isinstance(s.friction, str) else "slide")
    names.append("throw")
    for f in d.faces:
        names += ["bounce_cond", "bounce_general_cond"] if f.contact == "impact_pair" else ["bounce",
                                                                                             "bounce_general"]
    return tuple(dict.fromkeys(names))


_CHAINS: dict[str, ComposedChain] = {}


def chain_for(task: str) -> Chain:
    """The composed skill chain of task ``task`` (any registered task name, e.g. ``"launch"``,
    ``"launch-bounce-varied"``; built once per process); ``ValueError`` naming the known tasks."""
    import phyplan_envs

    if task not in phyplan_envs.ALL_TASKS:
        raise ValueError(f"task {task!r} has no skill chain: it is not a registered task; tasks: "
                         f"{', '.join(phyplan_envs.ALL_TASKS)}")
    if task not in _CHAINS:
        _CHAINS[task] = ComposedChain(task)
    c = _CHAINS[task]
    return Chain(task, c.skills, c.rollout)
