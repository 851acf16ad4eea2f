"""Batched queries of time-parameterised skill models: "when does this happen, and what is the state then?".

The skill models of :mod:`phyplan_agents.skills` map (initial condition, query time t) to the state at t. A skill
chain needs event states instead: the pendulum's speed when it reaches the bottom of its arc, the horizontal range
of a throw when the object reaches the landing height, the point where a sliding object stops. Each query here
answers one such question for a whole batch of initial conditions at once (Algorithm 3's "while s is not finished:
query the model at the next time step", vectorised):

1. the model is evaluated on a coarse time grid for every distinct row of the batch (one ``predict`` call);
2. the first grid interval where the watched output crosses its level brackets the event time;
3. a few Illinois (modified regula falsi) steps on the network itself refine the time inside the bracket
   (one ``predict`` call of ``N`` rows each), so the result does not depend on the grid spacing;
4. the outputs at the refined time are read off (one more call).

The searched time range is the model's training range of its time input (``model.spec.ranges``, see
:mod:`phyplan_envs.skill_scenes`), so the networks are never queried at times they did not learn; models without a
``spec`` (e.g. test stand-ins) use the ``*_T_MAX`` defaults below. Rows whose output never crosses the level inside
the range take the grid time whose output is closest to the level (for a throw that never reaches the floor: the
end of the range), and are reported in the returned ``valid`` mask.

Every function takes and returns float32 torch tensors of shape ``(N,)`` and never builds autograd graphs.
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from typing import NamedTuple

import numpy as np
import torch

# Time ranges searched for models that do not declare theirs. They cover the tasks' physics with margin (a
# pendulum released from at most pi/2 reaches the bottom after ~0.33 s; the longest fall, Bounce's 1.5 m drop onto
# the wedge, lasts ~0.5 s; the longest slide, 1.6 m at mu 0.2, lasts ~1.3 s).
SWING_T_MAX = 0.6      # s
THROW_T_MAX = 1.0      # s
SLIDE_T_MAX = 1.7      # s
GRID_POINTS = 5        # grid points per query. Each watched output crosses its level once in the searched range
                       # (swing: theta < 0 from the bottom to the far side; throw: y keeps falling; slide: v keeps
                       # decreasing; x rises until the stop, the end of its range), so any grid brackets it; more
                       # points only shorten the bracket that the Illinois steps start from
REFINE_STEPS = 6       # Illinois steps after bracketing: answers within ~1e-5 m of an 80-point grid + 12 steps


@dataclass
class Event:
    """The result of a crossing query: event time ``t`` (s), the model outputs there ``y`` (N, n_out), and
    ``valid`` (N,) bool: false where the level was not crossed inside the searched time range."""

    t: torch.Tensor
    y: torch.Tensor
    valid: torch.Tensor


def _distinct_rows(x: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor]:
    """The distinct rows of a 2-d float32 tensor and the inverse index (``distinct[inverse] == x``).

    Rows are compared byte for byte (NumPy's ``unique`` on a void view: ~10x faster than ``torch.unique(dim=0)``).
    """
    a = np.ascontiguousarray(x.numpy())
    v = a.view(np.dtype((np.void, a.dtype.itemsize * a.shape[1]))).ravel()
    _, first, inverse = np.unique(v, return_index=True, return_inverse=True)
    return torch.from_numpy(a[first]), torch.from_numpy(inverse.reshape(-1).astype(np.int64))


def _first_true(mask: torch.Tensor) -> torch.Tensor:
    """The index of the first True along dim 1 (0 where there is none). ``torch.max`` of a bool tensor returns the
    first maximal index, as ``argmax`` does, at a fraction of the cost of ``argmax`` over a float copy."""
    return torch.max(mask, dim=1).indices


def _predict(model, x: torch.Tensor) -> torch.Tensor:
    with torch.no_grad():
        out = model.predict(x)
    out = torch.as_tensor(out, dtype=torch.float32)
    if out.ndim != 2 or out.shape[0] != x.shape[0]:
        raise ValueError(f"skill model {getattr(model, 'name', model)!r} returned shape {tuple(out.shape)} for "
                         f"{x.shape[0]} inputs; expected (N, n_out)")
    return out


def time_range(model, default_t_max: float) -> tuple[float, float]:
    """The (t_min, t_max) a skill model was trained on (its spec's time-input range), else (0, default_t_max)."""
    spec = getattr(model, "spec", None)
    k = getattr(spec, "time_input", None)
    if k is None:
        return 0.0, float(default_t_max)
    lo, hi = spec.ranges[k]
    return float(lo), float(hi)


def first_crossing(model, inputs: torch.Tensor, out_index: int, level: torch.Tensor | float,
                   t_max: torch.Tensor | float, direction: int = -1, t_min: torch.Tensor | float = 0.0,
                   grid_points: int | None = None, refine_steps: int | None = None) -> Event:
    """The first time in ``[t_min, t_max]`` at which output ``out_index`` crosses ``level``, batched.

    Args:
        model: a skill model whose ``predict(x)`` takes rows ``(*inputs, t)`` and returns ``(N, n_out)``.
        inputs: ``(N, n_in - 1)`` initial conditions (the query time is appended as the last column).
        out_index: which output to watch.
        level: the level, a scalar or ``(N,)``.
        t_max, t_min: the searched time range (s), scalars or ``(N,)``.
        direction: ``-1`` for a downward crossing (output goes from above the level to at or below it), ``+1`` for
            an upward one.
        grid_points: grid size of the bracketing pass (default :data:`GRID_POINTS`); refine_steps: Illinois steps
            inside the bracket (default :data:`REFINE_STEPS`).

    Repeated rows are computed once: the grid pass runs on the distinct (inputs, range), the refinement on the
    distinct (inputs, range, level) (a refinement grid of candidate actions repeats most upstream quantities).
    """
    grid_points = GRID_POINTS if grid_points is None else int(grid_points)
    refine_steps = REFINE_STEPS if refine_steps is None else int(refine_steps)
    inputs = torch.as_tensor(inputs, dtype=torch.float32)
    n = inputs.shape[0]
    level = torch.as_tensor(level, dtype=torch.float32).expand(n)
    t_lo = torch.as_tensor(t_min, dtype=torch.float32).expand(n)
    t_hi = torch.as_tensor(t_max, dtype=torch.float32).expand(n)
    key, inverse = _distinct_rows(torch.cat([inputs, t_lo[:, None], t_hi[:, None], level[:, None]], dim=1))
    if key.shape[0] < n:
        ev = first_crossing(model, key[:, :-3], out_index, key[:, -1], key[:, -2], direction, key[:, -3],
                            grid_points, refine_steps)
        return Event(t=ev.t[inverse], y=ev.y[inverse], valid=ev.valid[inverse])
    frac_grid = torch.linspace(0.0, 1.0, grid_points)
    distinct, which = _distinct_rows(torch.cat([inputs, t_lo[:, None], t_hi[:, None]], dim=1))
    m = distinct.shape[0]
    d_in, d_lo, d_hi = distinct[:, :-2], distinct[:, -2], distinct[:, -1]
    d_grid = d_lo[:, None] + (d_hi - d_lo)[:, None] * frac_grid               # (m, G)
    rows = torch.cat([d_in.repeat_interleave(grid_points, 0), d_grid.reshape(-1, 1)], dim=1)
    values = _predict(model, rows)[:, out_index].reshape(m, grid_points)[which]
    grid = d_grid[which]                                                     # (n, G)
    g = (values - level[:, None]) * (-direction)
    # g > 0 before the event, g <= 0 at or after it
    after = g <= 0
    after[:, 0] = False                      # an event exactly at t_min counts only if the output starts above
    has = after.any(dim=1)
    k = torch.where(has, _first_true(after), torch.zeros_like(has, dtype=torch.long))
    k = k.clamp(min=1)
    lo_t = grid.gather(1, (k - 1)[:, None])[:, 0]
    hi_t = grid.gather(1, k[:, None])[:, 0]
    lo_g = g.gather(1, (k - 1)[:, None])[:, 0]
    hi_g = g.gather(1, k[:, None])[:, 0]
    t = _illinois(lo_t, hi_t, lo_g, hi_g, refine_steps,
                  lambda t: (_predict(model, torch.cat([inputs, t[:, None]], dim=1))[:, out_index] - level)
                  * (-direction))
    # no crossing: the grid time whose output is closest to the level
    t_closest = grid.gather(1, g.abs().argmin(dim=1)[:, None])[:, 0]
    t = torch.where(has, t, t_closest)
    y = _predict(model, torch.cat([inputs, t[:, None]], dim=1))
    return Event(t=t, y=y, valid=has)


def _illinois(lo_t, hi_t, lo_g, hi_g, steps: int, g_of_t) -> torch.Tensor:
    """Illinois (modified regula falsi) steps inside brackets ``[lo_t, hi_t]`` with ``g(lo) > 0 >= g(hi)``;
    ``g_of_t(t)`` evaluates the watched function at times ``t`` (one per row). Returns the final interpolated t."""
    side = torch.zeros(lo_t.shape[0], dtype=torch.int8)  # which end was kept last time
    for _ in range(steps):
        denom = lo_g - hi_g
        frac = torch.where(denom.abs() > 1e-12, lo_g / denom, torch.full_like(denom, 0.5)).clamp(0.0, 1.0)
        t = lo_t + frac * (hi_t - lo_t)
        gt = g_of_t(t)
        above = gt > 0
        # keep the bracket [lo, hi] with g(lo) > 0 >= g(hi); halve the stale end's value (Illinois)
        lo_t = torch.where(above, t, lo_t)
        hi_t = torch.where(above, hi_t, t)
        new_lo_g = torch.where(above, gt, lo_g)
        new_hi_g = torch.where(above, hi_g, gt)
        new_hi_g = torch.where(above & (side == 1), new_hi_g * 0.5, new_hi_g)
        new_lo_g = torch.where(~above & (side == -1), new_lo_g * 0.5, new_lo_g)
        lo_g, hi_g = new_lo_g, new_hi_g
        side = torch.where(above, torch.ones_like(side), -torch.ones_like(side))
    denom = lo_g - hi_g
    frac = torch.where(denom.abs() > 1e-12, lo_g / denom, torch.full_like(denom, 0.5)).clamp(0.0, 1.0)
    return lo_t + frac * (hi_t - lo_t)


def swing_bottom_speed(swing, theta0: torch.Tensor, length: float) -> torch.Tensor:
    """Speed (m/s) of the bob at the bottom of its arc for release angles ``theta0`` (rad from vertical).

    Swing model ``(theta_init, t) -> (theta, omega)``: the first time theta crosses 0, bob speed = |omega| * l with
    ``length`` = l, the pendulum's length (m; a task fact, e.g. ``facts.pendulum_length``).
    """
    theta0 = torch.as_tensor(theta0, dtype=torch.float32)
    t0, t1 = time_range(swing, SWING_T_MAX)
    ev = first_crossing(swing, theta0[:, None], out_index=0, level=0.0, t_min=t0, t_max=t1, direction=-1)
    return ev.y[:, 1].abs() * length


def hit_speed(hit, m_bob: float, m_obj: float, v_bob: torch.Tensor) -> torch.Tensor:
    """Speed (m/s) of an object of mass ``m_obj`` (kg) struck by a bob of mass ``m_bob`` moving at ``v_bob``.

    Hit model ``(m1, m2, v_init) -> (v,)``.
    """
    v_bob = torch.as_tensor(v_bob, dtype=torch.float32)
    n = v_bob.shape[0]
    x = torch.stack([torch.full((n,), float(m_bob)), torch.full((n,), float(m_obj)), v_bob], dim=1)
    return _predict(hit, x)[:, 0]


def throw_landing(throw, v_hor: torch.Tensor, v_ver: torch.Tensor, drop: torch.Tensor | float) -> Event:
    """Where a thrown object reaches ``drop`` metres below its release point (first downward crossing).

    Throw model ``(v_hor, v_ver, t) -> (x, y, v_ver)`` with y the vertical displacement (up-positive). Returns the
    :class:`Event`; ``event.y[:, 0]`` is the horizontal distance (m), ``event.y[:, 2]`` the vertical speed there.
    """
    v_hor = torch.as_tensor(v_hor, dtype=torch.float32)
    v_ver = torch.as_tensor(v_ver, dtype=torch.float32).expand_as(v_hor)
    level = -torch.as_tensor(drop, dtype=torch.float32).expand_as(v_hor)
    t0, t1 = time_range(throw, THROW_T_MAX)
    return first_crossing(throw, torch.stack([v_hor, v_ver], dim=1), out_index=1, level=level,
                          t_min=t0, t_max=t1, direction=-1)


def _slide_inputs(v0: torch.Tensor, condition) -> torch.Tensor:
    """The slide model's inputs before the query time: ``(*condition, v_init)`` per row."""
    if condition is None:
        return v0[:, None]
    c = torch.as_tensor(condition, dtype=torch.float32).reshape(v0.shape[0], -1)
    return torch.cat([c, v0[:, None]], dim=1)


def slide_stop(slide, v0: torch.Tensor, condition: torch.Tensor | None = None) -> torch.Tensor:
    """Distance (m) an object launched at ``v0`` (m/s) slides before it stops.

    Slide model ``(v_init, t) -> (x, v)``: the first time v crosses 0, read x there. A conditioned slide model
    (``slide_cond``: ``(friction, v_init, t)``) takes its leading inputs per row from ``condition`` ``(N, c)``.
    """
    v0 = torch.as_tensor(v0, dtype=torch.float32)
    t0, t1 = time_range(slide, SLIDE_T_MAX)
    ev = first_crossing(slide, _slide_inputs(v0, condition), out_index=1, level=0.0, t_min=t0, t_max=t1,
                        direction=-1)
    return ev.y[:, 0]


def slide_until(slide, v0: torch.Tensor, distance: torch.Tensor | float,
                condition: torch.Tensor | None = None) -> Event:
    """When and at what speed an object launched at ``v0`` has slid ``distance`` metres (e.g. a table's edge).

    Returns the :class:`Event` of x crossing ``distance`` upwards; ``event.valid`` is false where the object stops
    first (then ``event.y`` holds the state closest to the distance, i.e. where it stopped). ``condition``: as in
    :func:`slide_stop`.
    """
    v0 = torch.as_tensor(v0, dtype=torch.float32)
    inputs = _slide_inputs(v0, condition)
    t0, t1 = time_range(slide, SLIDE_T_MAX)
    stop = first_crossing(slide, inputs, out_index=1, level=0.0, t_min=t0, t_max=t1, direction=-1)
    dist = torch.as_tensor(distance, dtype=torch.float32).expand_as(v0)
    # x grows monotonically until the stop: search the edge crossing there only
    ev = first_crossing(slide, inputs, out_index=0, level=dist, t_min=t0, t_max=stop.t, direction=+1)
    reached = ev.valid
    y = torch.where(reached[:, None], ev.y, stop.y)
    t = torch.where(reached, ev.t, stop.t)
    return Event(t=t, y=y, valid=reached)


EVENT_GRID_POINTS = 17   # grid points of a many-event query (a flight past faces): a 62 ms step over a 1 s flight.
                         # A ball's distance from a plane is linear in t (vertical faces) or a parabola, so it
                         # crosses at most twice; a 3 m/s ball moves 19 cm a step, less than a wedge's face
EVENT_CHUNK = 4          # grid intervals evaluated at a time when the query has final events (see first_events)


class Crossings(NamedTuple):
    """The result of :func:`first_events`: per row and event the first crossing time ``t`` (N, M) and whether there
    was one ``valid`` (N, M); per row the time its search reached ``horizon`` (N,): inf where it covered the whole
    range, else the last grid time evaluated (an event first crossing later is reported as not crossed)."""

    t: torch.Tensor
    valid: torch.Tensor
    horizon: torch.Tensor


def _sure_ends(ends, cross, final, y_chunk, y_last, grid, lo: int, hi: int, live) -> torch.Tensor:
    """Per live row, whether an event other than the final ones crosses in the chunk's intervals (``cross``
    (L, w, M), the first one the interval ending at the chunk's first point) between two points where ``ends``
    holds (:func:`first_events`); ``ends`` is asked only at the ends of those intervals."""
    ended = torch.zeros(len(live), dtype=torch.bool)
    cand = cross.clone()
    cand[:, :, final] = False
    rows, j, col = cand.nonzero(as_tuple=True)
    if len(rows) == 0:
        return ended
    y_seg = torch.cat([y_last[live][:, None], y_chunk], dim=1) if lo else y_chunk
    t_seg = grid[max(lo - 1, 0):hi]
    i = live[rows]
    sure = ends(y_seg[rows, j], t_seg[j], i, col) & ends(y_seg[rows, j + 1], t_seg[j + 1], i, col)
    ended[rows[sure]] = True
    return ended


def first_events(model, inputs: torch.Tensor, measure, t_min: float, t_max: float,
                 grid_points: int = EVENT_GRID_POINTS, refine_steps: int | None = None,
                 final: tuple[int, ...] = (), measure_one=None, ends=None) -> Crossings:
    """The first time each of M event functions of a skill model's outputs crosses 0 downwards, batched.

    Args:
        model: a time-parameterised skill model (rows ``(*inputs, t)``).
        inputs: ``(N, n_in - 1)`` initial conditions.
        measure: ``measure(y, t, idx) -> (R, M)``: the event functions at outputs ``y`` ``(R, n_out)`` and times
            ``t`` ``(R,)`` of the rows ``idx`` ``(R,)`` of the batch (e.g. a flying ball's distance from each of M
            planes); positive before the event.
        t_min, t_max: the searched time range (s).
        final: the events (column indices) that end the motion wherever they happen, e.g. a flight's ground. The
            grid is then evaluated :data:`EVENT_CHUNK` intervals at a time, and a row's search stops after the
            chunk in which a final event crosses: no event crossing in a later interval can come first.
        measure_one: optional ``measure_one(y, t, idx, col) -> (R,)``, the event function ``col`` (R,) of each row
            alone (what ``measure(y, t, idx)[k, col[k]]`` gives), for the refinement steps; without it they evaluate
            every event function and keep one.
        ends: optional ``ends(y, t, idx, col) -> (R,)`` bool: whether a crossing of event ``col`` (R,) next to the
            point (outputs ``y`` (R, n_out) at times ``t`` of rows ``idx``) would surely end the motion (e.g. a ball
            well inside a face when it reaches the face's plane). The grid is then evaluated in chunks as with
            ``final``, and a row's search also stops after the chunk in which an event crosses between two points
            where ``ends`` holds. Whether the motion really ended there is the caller's to check against
            ``horizon``.

    Returns the :class:`Crossings`: ``t`` and ``valid``, each ``(N, M)``: the crossing times and whether there was
    one in the searched range (``t_max`` where there was none), and each row's ``horizon``. The grid pass runs on
    the distinct rows of ``inputs``; the functions that cross in a row's earliest crossing interval are refined by
    Illinois steps, the later ones are interpolated linearly inside their interval. An event whose first crossing
    comes after the chunk where a row's search stopped is reported as not crossed.
    """
    refine_steps = REFINE_STEPS if refine_steps is None else int(refine_steps)
    inputs = torch.as_tensor(inputs, dtype=torch.float32)
    n = inputs.shape[0]
    grid = torch.linspace(float(t_min), float(t_max), int(grid_points))
    g_n = len(grid)
    final = list(final)
    distinct, inverse = _distinct_rows(inputs)
    g = None                                   # (N, G, M); NaN at grid points not evaluated (no crossing there)
    y_last = None                              # (N, n_out): each row's outputs at the last point evaluated
    active = torch.ones(n, dtype=torch.bool)
    horizon = torch.full((n,), math.inf)
    chunked = bool(final) or ends is not None
    lo = 0
    while lo < g_n and bool(active.any()):
        hi = min(g_n, lo + EVENT_CHUNK + (0 if lo else 1)) if chunked else g_n
        pts, width = grid[lo:hi], hi - lo
        live = active.nonzero()[:, 0]
        d_sel, d_inv = torch.unique(inverse[live], return_inverse=True)
        d_rows = torch.cat([distinct[d_sel].repeat_interleave(width, 0), pts.repeat(len(d_sel))[:, None]], dim=1)
        y = _predict(model, d_rows).reshape(len(d_sel), width, -1)[d_inv].reshape(len(live) * width, -1)
        t_c, i_c = pts.repeat(len(live)), live.repeat_interleave(width)
        g_c = measure(y, t_c, i_c).reshape(len(live), width, -1)
        if g is None:
            g = torch.full((n, g_n, g_c.shape[2]), float("nan"))
        g[live, lo:hi] = g_c
        if chunked:                            # the chunk's intervals, with the one that ends at its first point
            seg = g[live, max(lo - 1, 0):hi]
            cross = (seg[:, :-1] > 0) & (seg[:, 1:] <= 0)                                     # (L, w, M)
            ended = cross[:, :, final].flatten(1).any(dim=1)
            if ends is not None:
                ended |= _sure_ends(ends, cross, final, y.reshape(len(live), width, -1), y_last, grid, lo, hi, live)
                if y_last is None:
                    y_last = torch.zeros(n, y.shape[1])
                y_last[live] = y.reshape(len(live), width, -1)[:, -1]
            active[live[ended]] = False
            if hi < g_n:
                horizon[live[ended]] = pts[-1]
        lo = hi
    m = g.shape[2]
    cross = (g[:, :-1] > 0) & (g[:, 1:] <= 0)                                                  # (N, G-1, M)
    valid = cross.any(dim=1)
    k = torch.where(valid, _first_true(cross), torch.full((n, m), g_n - 2, dtype=torch.long))
    lo_t, hi_t = grid[k], grid[k + 1]
    lo_g = g.gather(1, k[:, None, :])[:, 0]
    hi_g = g.gather(1, (k + 1)[:, None, :])[:, 0]
    denom = lo_g - hi_g
    frac = torch.where(denom.abs() > 1e-12, lo_g / denom, torch.full_like(denom, 0.5)).clamp(0.0, 1.0)
    t = torch.where(valid, lo_t + frac * (hi_t - lo_t), torch.full_like(lo_t, float(t_max)))    # interpolated
    first = torch.where(valid, k, torch.full_like(k, g_n)).min(dim=1, keepdim=True).values
    refine = valid & (k == first)
    r, c = refine.nonzero(as_tuple=True)
    if len(r):
        rows = inputs[r]
        if measure_one is None:
            def one(y, tt):
                return measure(y, tt, r).gather(1, c[:, None])[:, 0]
        else:
            def one(y, tt):
                return measure_one(y, tt, r, c)
        t[r, c] = _illinois(lo_t[r, c], hi_t[r, c], lo_g[r, c], hi_g[r, c], refine_steps,
                            lambda tt: one(_predict(model, torch.cat([rows, tt[:, None]], dim=1)), tt))
    return Crossings(t, valid, horizon)
