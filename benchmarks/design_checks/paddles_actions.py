"""Paddles-N's actions for the design checks: the task without the Panda (:func:`make`, or a study's other paddle size,
tilt, restitution or timestep, :class:`Design`, and its cost per episode, :func:`episode_cost`), one attempt and the
paddles its ball meets (:func:`attempt`, :func:`met_paddles`), and *chain actions*, whose ball meets every paddle,
drawn paddle by paddle (:func:`chain_action`: the release angle uniform, then each placed paddle's action value
uniform among the points of a 0.05 m grid over its bounds where the ball, with the paddles before it as drawn, meets
it, jittered by U(-0.025, 0.025) m; or :func:`aimed_action`: each placed paddle put where the ball's flight meets
its face at a point uniform along it, one episode per paddle). The checks that use them:
:mod:`benchmarks.design_checks.paddles`, :mod:`benchmarks.design_checks.paddles_bypass`, :mod:`benchmarks.depth`.
"""
from __future__ import annotations

import math
import time
from dataclasses import dataclass, replace

import gymnasium as gym
import numpy as np

import phyplan_envs  # noqa: F401  (registers the ids)
from phyplan_envs import assets
from phyplan_envs.end_rule import chunk_for

GRID_STEP = 0.05         # m: the grid over each placed paddle's action bounds that chain actions are drawn on
JITTER = 0.025
AIM_MARGIN = 0.03        # m: aimed chain actions meet each face at least this far from its edges
HIT_GAP = 0.004          # m: the centre within this of the face's contact distance: the ball meets the face
EDGE = 0.5               # m: the task's paddle edge
TILT = 45.0              # degrees: the task's paddle tilt from horizontal
VARIED_OF = {0: 0, 1: 1, 2: 3}   # the PaddlesVaried version on each Paddles version (the current one; v2 is on
#                                  Paddles-v2 too: Design.varied_version)
VERSION = 2              # the Paddles version checked (0: absolute placement; 1, 2: each paddle's offset, v1 with a
#                          4 s episode cap at every N, v2's growing with N beyond N = 6; the same up to N = 6)


@dataclass(frozen=True)
class Design:
    """A Paddles design the checks run: the task's (the defaults: ``PhyPlan/Paddles-v<version>``) or a study's.

    Attributes:
        edge, tilt: the square paddles' edge (m) and tilt from horizontal (degrees).
        version: the Paddles version (0: absolute placement; 1 and 2: each paddle's offset, with a 4 s episode cap
            (v1) or one growing with N beyond N = 6 (v2)).
        restitution: the ball-paddle restitution (0: the task's contact, which keeps none of the normal speed; > 0:
            a soft contact of that restitution, so that the ball bounces off the paddles).
        timestep: the simulation timestep (s; None: the task's 0.5 ms), the end rule still every 5 ms.
        offset_span: v1's offset bounds (m; None: the task's 0.45-0.9 m).
        max_sim_time: the episode cap (s; None: the task's 4 s): a bouncing ball falls through five or more paddles
            for longer.
        samples_only: whether the face test of a bouncing design (``restitution`` > 0) looks at the flight's samples
            alone, as the task's does, instead of between them too (:func:`met_paddles`; the restitution table of
            docs/depth.md was measured so).
        varied_version: the PaddlesVaried version a ``physics_space`` keyword makes (None: the current one on
            Paddles-v<version>, :data:`VARIED_OF`).
    """

    edge: float = EDGE
    tilt: float = TILT
    version: int = VERSION
    restitution: float = 0.0
    timestep: float | None = None
    offset_span: tuple[float, float] | None = None
    max_sim_time: float | None = None
    samples_only: bool = False
    varied_version: int | None = None

    def is_task(self) -> bool:
        """Whether this is the registered task of its version (no study)."""
        return replace(self, samples_only=False, varied_version=None) == Design(version=self.version)

    def study_class(self) -> type:
        """The study's task class (a subclass of Paddles-v<version> that sets the study's class attributes)."""
        from phyplan_envs.tasks.paddles import PaddlesEnv
        from phyplan_envs.tasks.paddles_v0 import PaddlesEnvV0
        from phyplan_envs.tasks.paddles_v1 import PaddlesEnvV1

        attrs = {"paddle_half": self.edge / 2, "paddle_tilt": math.radians(self.tilt),
                 "paddle_restitution": float(self.restitution),
                 "face_test_between": self.restitution > 0 and not self.samples_only}
        if self.timestep is not None:
            attrs.update(timestep=float(self.timestep), chunk=chunk_for(self.timestep))
        if self.offset_span is not None:
            attrs["offset_span"] = tuple(map(float, self.offset_span))
        if self.max_sim_time is not None:
            attrs["max_sim_time"] = float(self.max_sim_time)
        name = (f"PaddlesEnvV{self.version}Edge{self.edge:g}Tilt{self.tilt:g}E{self.restitution:g}"
                f"Dt{self.timestep or 0:g}Cap{self.max_sim_time or 0:g}")
        return type(name, ((PaddlesEnvV0, PaddlesEnvV1, PaddlesEnv)[self.version],), attrs)

    def make(self, n: int, **kwargs):
        """Paddles-``n`` of this design without the Panda; the task's with a ``physics_space`` keyword: PaddlesVaried
        (``varied_version``; a study has no hidden physics)."""
        if self.is_task():
            if kwargs.get("physics_space"):
                v = VARIED_OF[self.version] if self.varied_version is None else self.varied_version
                return gym.make(f"PhyPlan/PaddlesVaried-v{v}", paddles=n, with_panda=False, **kwargs).unwrapped
            return gym.make(f"PhyPlan/Paddles-v{self.version}", paddles=n, with_panda=False, **kwargs).unwrapped
        if kwargs.get("physics_space"):
            raise ValueError("a study of the paddles has no hidden physics: physics_space needs the task's design")
        return self.study_class()(paddles=n, with_panda=False, **kwargs)


TASK = Design()


class FixedPhysics:
    """A varied env whose every reset passes the ``physics`` reset option ``physics`` (the privileged option of
    :class:`phyplan_envs.hidden_physics.HiddenPhysics`: these hidden values instead of the context's); every other
    attribute is the env's. The checks' functions run on it as on the env."""

    def __init__(self, env, physics: dict):
        self.env, self.physics = env, dict(physics)

    def __getattr__(self, name):
        return getattr(self.env, name)

    def reset(self, *, seed=None, options=None):
        options = dict(options or {})
        options.setdefault("physics", self.physics)
        return self.env.reset(seed=seed, options=options)


def episode_cost(n: int, k: int, seed: int, design: Design) -> tuple[float, float]:
    """CPU seconds per episode of ``k`` uniform random actions (``default_rng(seed)``) on the context of
    ``reset(seed=seed)``, the least of 3 timings: on ``design``'s task and on the task of its version."""
    out = []
    for d in (design, Design(version=design.version)):
        env = d.make(n)
        env.reset(seed=seed)
        context = env.context
        rng = np.random.default_rng(seed)
        acts = rng.uniform(env.action_low, env.action_high, size=(k, len(env.action_low)))
        times = []
        for _ in range(3):
            t0 = time.process_time()
            for a in acts:
                env.reset(options={"context": context})
                env.step(a)
            times.append((time.process_time() - t0) / k)
        out.append(min(times))
    return out[0], out[1]


def make(n: int, edge: float = EDGE, tilt: float = TILT, version: int = VERSION, **kwargs):
    """Paddles-``n`` (``PhyPlan/Paddles-v<version>``) without the Panda; with ``edge`` (m) or ``tilt`` (degrees)
    other than the task's 0.5 m and 45 degrees, its paddles that size and tilt (a study); with a ``physics_space``
    keyword, ``PhyPlan/PaddlesVaried-v<version>`` (:meth:`Design.make`)."""
    return Design(edge, tilt, version).make(n, **kwargs)


def grid(lo: float, hi: float) -> np.ndarray:
    """The points every ``GRID_STEP`` over [lo, hi] (both ends in)."""
    return np.linspace(lo, hi, int(round((hi - lo) / GRID_STEP)) + 1)


def board_gap(face, points, radius: float, half: float) -> np.ndarray:
    """Per point (rows x, y, z), how far a ball of ``radius`` centred there is from touching the square board of
    half edge ``half`` under ``face`` (``PADDLE_THICK`` thick): its face, an edge or a corner."""
    n, c = face.normal[0], face.vertices[0].mean(axis=0)
    down = np.cross(n, (0.0, 1.0, 0.0))
    local = np.stack([(points - c) @ down, points[:, 1] - c[1], (points - c) @ n], axis=1)
    nearest = np.clip(local, (-half, -half, -assets.PADDLE_THICK), (half, half, 0.0))
    return np.linalg.norm(local - nearest, axis=1) - radius


def met_paddles(env, action, trajectory, board: bool = False, between: bool | None = None) -> list[bool]:
    """Per paddle, whether the recorded flight (rows ``t, x, y, z``) met its face: the ball's centre came within
    ``HIT_GAP`` of touching it inside the face (the chain actions' test). At the samples; with ``between`` (default:
    a study class's ``face_test_between``, true for a bouncing design: :class:`Design`) also on the free flight from
    each sample towards the next (:func:`free_flights`), since a bounce is briefer than the samples' 5 ms and its
    touch falls between them. On the task's overdamped paddles the ball glides down each face over many samples,
    and the task's figures were measured at the samples alone; that test does not count a touch near a face's lower
    edge that is deeper than ``HIT_GAP`` at every sample (``python -m benchmarks.design_checks.paddles --face-test
    K`` counts the actions where the two tests differ). With ``board``, whether it came that close to touching the
    board anywhere: its face, an edge or a corner (the board is ``PADDLE_THICK`` thick under the face), on the path
    between the samples too (a brief touch of an edge falls between them; straight lines 1/10 of a sample apart,
    off the flight's arc by under 0.1 mm)."""
    if board:
        p = np.asarray(trajectory, dtype=np.float64)[:, 1:]
        r, h = env.facts.ball_radius, env.facts.paddle_half
        if len(p) > 1:
            w = np.linspace(0.0, 1.0, 10, endpoint=False)[None, :, None]
            p = np.concatenate([(p[:-1, None] * (1 - w) + p[1:, None] * w).reshape(-1, 3), p[-1:]])
        return [bool(np.any(board_gap(face, p, r, h) < HIT_GAP)) for face in env.describe(action).faces]
    return [k is not None for k in first_meetings(env, action, trajectory, between)]


def first_meetings(env, action, trajectory, between: bool | None = None) -> list[int | None]:
    """Per paddle, the first sample of the recorded flight (rows ``t, x, y, z``) at which, or on whose free flight
    towards the next sample, the ball meets the paddle's face (:func:`met_paddles`' face test); None if it does
    not."""
    rows = np.asarray(trajectory, dtype=np.float64)
    p = rows[:, 1:]
    r, h = env.facts.ball_radius, env.facts.paddle_half
    if between is None:
        between = getattr(env, "face_test_between", False)
    parts = 20
    flights = free_flights(rows, -float(env.scene.model.opt.gravity[2]), parts) if between and len(p) > 2 else None
    out = []
    for face in env.describe(action).faces:
        n, c = face.normal[0], face.vertices[0].mean(axis=0)
        down = np.cross(n, (0.0, 1.0, 0.0))

        def meets(q):
            return (np.abs((q - c) @ n - r) < HIT_GAP) & (np.abs((q - c) @ down) <= h + 0.01)

        hit = meets(p)
        if flights is not None:
            hit[1:-1] |= meets(flights).reshape(-1, parts).any(axis=1)
        out.append(int(np.argmax(hit)) if hit.any() else None)
    return out


def arrival_speeds(env, action, trajectory) -> list[float]:
    """Per paddle, the ball's speed (m/s) when it first meets the paddle's face (:func:`first_meetings`): at that
    sample, from it and the sample before it under free flight; NaN where it does not meet it."""
    rows = np.asarray(trajectory, dtype=np.float64)
    g = -float(env.scene.model.opt.gravity[2])
    out = []
    for k in first_meetings(env, action, rows):
        if k is None or k == 0:
            out.append(float("nan"))
            continue
        dt = rows[k, 0] - rows[k - 1, 0]
        v = (rows[k, 1:] - rows[k - 1, 1:]) / dt - np.array([0.0, 0.0, g * dt / 2])
        out.append(float(np.linalg.norm(v)))
    return out


def free_flights(rows: np.ndarray, g: float, parts: int = 20) -> np.ndarray:
    """The points (rows x, y, z) of the free flights from each sample of ``rows`` (``t, x, y, z``; from the second)
    towards the next, ``parts`` per interval (the sample itself left out): parabolas under gravity ``g`` (m/s^2,
    downwards) from the velocity at the sample that it and the sample before it give."""
    t, p = rows[:, 0], rows[:, 1:]
    dt = np.diff(t)[:, None]
    v = (p[1:-1] - p[:-2]) / dt[:-1] - np.array([0.0, 0.0, g]) * dt[:-1] / 2     # at samples 1 .. K-2
    tau = np.linspace(0.0, 1.0, parts + 1)[1:][None, :] * dt[1:]                   # (K-2, parts)
    pts = p[1:-1, None] + v[:, None] * tau[..., None]
    pts[..., 2] -= g * tau ** 2 / 2
    return pts.reshape(-1, 3)


def flight(env, context, action) -> tuple[float, dict]:
    """One attempt on ``context`` (the env records the flight): (reward, ``info``)."""
    env.reset(options={"context": context})
    _, reward, _, _, info = env.step(np.asarray(action, dtype=np.float64))
    return float(reward), info


def attempt(env, context, action, board: bool = False) -> tuple[float, float, list[bool]]:
    """One attempt on ``context``: (reward, landing x, the paddles met; with ``board``, touched anywhere:
    :func:`met_paddles`)."""
    reward, info = flight(env, context, action)
    return reward, float(info["final_pos"][0]), met_paddles(env, action, info["trajectory"], board)


def episode_ends(n: int, k: int, seed: int, design: Design, space: str | None = None) -> dict:
    """How ``k`` uniform random actions' episodes (``default_rng(seed)``) on the context of ``reset(seed=seed)`` of
    ``design``'s Paddles-``n`` end (with ``space``: on PaddlesVaried, action i on the context of ``reset(seed=seed +
    i)``, its restitution from that physics space): the count per ``info["end_reason"]`` (``reasons``: ``landed``,
    ``rest`` or ``timeout``, the cap passing with the ball in the air) and the simulated seconds (``sim_time``, per
    action)."""
    env = design.make(n, physics_space=space) if space else design.make(n)
    env.reset(seed=seed)
    context = env.context
    rng = np.random.default_rng(seed)
    reasons, sim_time = {}, []
    for i in range(k):
        if space:
            env.reset(seed=seed + i)
            context = env.context
        _, info = flight(env, context, rng.uniform(env.action_low, env.action_high))
        reasons[info["end_reason"]] = reasons.get(info["end_reason"], 0) + 1
        sim_time.append(info["sim_time"])
    return {"reasons": reasons, "sim_time": np.array(sim_time)}


def face_tests(n: int, k: int, seed: int, design: Design) -> dict:
    """The face test at the samples against the one on the free flights between them too (:func:`met_paddles`'s
    ``between``) on ``k`` uniform random actions (``default_rng(seed)``) on the context of ``reset(seed=seed)`` of
    ``design``'s Paddles-``n``: per paddle, how many actions' balls each test says met it (``samples``,
    ``between``), and how many actions the tests disagree on (``differ``)."""
    env = design.make(n, record_trajectory=True)
    env.reset(seed=seed)
    context = env.context
    rng = np.random.default_rng(seed)
    samples, between, differ = np.zeros(n, dtype=int), np.zeros(n, dtype=int), 0
    for _ in range(k):
        a = rng.uniform(env.action_low, env.action_high)
        _, info = flight(env, context, a)
        at = met_paddles(env, a, info["trajectory"], between=False)
        on = met_paddles(env, a, info["trajectory"], between=True)
        samples += at
        between += on
        differ += at != on
    return {"samples": samples, "between": between, "differ": differ}


def paddle_by_paddle(env, context, rng, choose) -> np.ndarray | None:
    """An action drawn paddle by paddle: the release angle uniform, then each placed paddle i's action value uniform
    among the points of :func:`grid` over its bounds that ``choose(i, met)`` marks (``met``: per grid point, the
    paddles the ball meets with the paddles before i as drawn and the later ones at their lower bound), jittered by
    U(-JITTER, JITTER) m. None when a paddle has no marked point."""
    n = env.paddles
    lo, hi = env.action_low, env.action_high
    a = np.empty(n)
    a[0] = rng.uniform(lo[0], hi[0])
    for i in range(1, n):
        points = grid(lo[i], hi[i])
        met = [attempt(env, context, np.concatenate([a[:i], [x], lo[i + 1:]]))[2] for x in points]
        pool = points[np.array(choose(i, met), dtype=bool)]
        if not len(pool):
            return None
        a[i] = np.clip(rng.choice(pool) + rng.uniform(-JITTER, JITTER), lo[i], hi[i])
    return a


def chain_action(env, context, rng) -> np.ndarray | None:
    """A chain action (module docstring), or None when a paddle has no grid point the ball meets."""
    return paddle_by_paddle(env, context, rng, lambda i, met: [all(m[:i + 1]) for m in met])


def aimed_action(env, context, rng) -> np.ndarray | None:
    """A chain action aimed paddle by paddle, one episode per placed paddle (the grid's draw runs one per grid point
    of each): the release angle uniform, then each placed paddle i put where the ball, with the paddles before it as
    drawn, meets its face at a point uniform along the face's downslope, at least ``AIM_MARGIN`` from its edges. The
    place comes from one episode with paddle i and the later ones at their lower bound: the ball's centre falls
    through the height where it touches the face at that point either on the recorded flight, before it first
    touches paddle i, or on the free flight extrapolated from the last two samples before that touch (a parabola
    under the scene's gravity). None when the ball does not fly free before it reaches paddle i or the place is
    outside the paddle's action bounds."""
    n = env.paddles
    lo, hi = env.action_low, env.action_high
    r, h = env.facts.ball_radius, env.facts.paddle_half
    g = -float(env.scene.model.opt.gravity[2])
    a = np.empty(n)
    a[0] = rng.uniform(lo[0], hi[0])
    for i in range(1, n):
        trial = np.concatenate([a[:i], lo[i:]])
        _, info = flight(env, context, trial)
        rows = np.asarray(info["trajectory"], dtype=np.float64)
        t, p = rows[:, 0], rows[:, 1:]
        faces = env.describe(trial).faces
        face = faces[i]
        normal, centre = face.normal[0], face.vertices[0].mean(axis=0)
        down = np.cross(normal, (0.0, 1.0, 0.0))
        touch = r * normal + rng.uniform(-(h - AIM_MARGIN), h - AIM_MARGIN) * down   # ball centre - face centre
        level = centre[2] + touch[2]
        touching = np.nonzero(board_gap(face, p, r, h) < HIT_GAP)[0]
        first = touching[0] if len(touching) else len(p)
        below = np.nonzero(p[:first, 2] < level)[0]
        if len(below) and below[0] > 0:                         # on the recorded flight: interpolated
            k = below[0]
            w = (p[k - 1, 2] - level) / (p[k - 1, 2] - p[k, 2])
            x = p[k - 1, 0] + w * (p[k, 0] - p[k - 1, 0])
        else:                                                   # extrapolated from the free flight before the touch
            if first < 2 or np.any(board_gap(faces[i - 1], p[first - 2:first], r, h) < HIT_GAP):
                return None
            dt = t[first - 1] - t[first - 2]
            v = (p[first - 1] - p[first - 2]) / dt - np.array([0.0, 0.0, g * dt / 2])
            z = p[first - 1, 2]
            if v[2] ** 2 + 2 * g * (z - level) < 0:
                return None
            tau = (v[2] + math.sqrt(v[2] ** 2 + 2 * g * (z - level))) / g
            x = p[first - 1, 0] + v[0] * tau
        x_face = x - touch[0]
        # paddle i's x is linear in its action value (v1: the paddle above's x plus the offset along the way; v0: it)
        x_lo, x_hi = (env.paddle_x(np.concatenate([a[:i], [v], lo[i + 1:]]))[0, i] for v in (lo[i], hi[i]))
        value = lo[i] + (x_face - x_lo) * (hi[i] - lo[i]) / (x_hi - x_lo)
        if not lo[i] <= value <= hi[i]:
            return None
        a[i] = value
    return a


def chain_actions(env, context, k: int, rng, tries: int = 5, aimed: bool = False) -> list[np.ndarray]:
    """``k`` chain actions (each meets every paddle when run), drawing up to ``tries * k`` times by
    :func:`chain_action` (with ``aimed``: :func:`aimed_action`)."""
    draw = aimed_action if aimed else chain_action
    out = []
    for _ in range(tries * k):
        if len(out) == k:
            break
        a = draw(env, context, rng)
        if a is not None and all(attempt(env, context, a)[2]):
            out.append(a)
    return out
