"""Do the varied tasks' contacts obey their set values? Restitution of the impacts, friction of the sliding block.

Used by ``python -m benchmarks.design_checks.hidden_physics --only restitution friction``. Every sample is one
context (``env.reset(seed=s)`` with the physics of its space) and one random action (:mod:`.seeds`):

* restitution: the context's impact (the bob's hit of the ball or block; the ball's bounce off the incline) measured
  one physics step at a time, set vs measured, once as the task runs and once with gravity switched off from the first
  touch to the separation (the calibration, :func:`phyplan_envs.hidden_physics.calibrated_damping`, is made without
  gravity: what is left without it is the calibration's own error);
* friction: the block's speed on each surface it slides on (Slide's table; Bridge's round table and plank), the
  deceleration / g fitted over a window of that surface, and in the same window the share of physics steps in which
  the block touches no part of that surface and its greatest height above its rest height on it (its hops).
"""
from __future__ import annotations

import math

import mujoco
import numpy as np

from phyplan_envs import assets
from phyplan_envs import hidden_physics as hp
from phyplan_envs.block import BLOCK_HALF
from phyplan_envs.base import PhyPlanEnv
from phyplan_envs.tasks.varied import BounceVariedEnv, BridgeVariedEnv, LaunchVariedEnv, SlideVariedEnv
from phyplan_envs.tasks.varied_v0 import BridgeVariedEnvV0, SlideVariedEnvV0

CLASSES: dict[str, type[PhyPlanEnv]] = {"launch": LaunchVariedEnv, "slide": SlideVariedEnv,
                                                "bounce": BounceVariedEnv, "bridge": BridgeVariedEnv}
"""The current version of each varied task."""
CLASSES_V0: dict[str, type[PhyPlanEnv]] = {"slide": SlideVariedEnvV0, "bridge": BridgeVariedEnvV0}
"""The superseded v0 of the varied tasks that have a v1 (the disc puck)."""
SLIDE_THETA = (1.2, math.pi / 2)   # release angles of the friction samples: fast enough to fill the windows
MIN_SPEED = 0.2                    # m/s: slower steps are left out of a friction window (the block is stopping)
TABLE_START = hp.PAD_RADIUS + 0.05   # m from the start: the table window begins (the block has left the pad)
PLANK_START = 0.15                 # m past the table's rim: the plank window begins (the 2 mm drop has settled)
END_CLEARANCE = 0.03               # m: a window ends this far before its surface's edge
BRIDGE_TABLE_STRETCH = (TABLE_START, assets.BRIDGE_TABLE_RADIUS - BLOCK_HALF * math.sqrt(2) - END_CLEARANCE)
"""Where Bridge's round-table window lies along the block's path (m from the start): its table's rim ends it."""
MIN_WINDOW_STEPS = 20              # a window with fewer steps is not fitted (the sample is counted as skipped)


def make(task: str, timestep: float | None = None, physics_space: str = "auto", version: int | None = None):
    """A varied env without the Panda; ``timestep`` overrides the task's (the convergence check halves it);
    ``version=0``: the superseded v0 of Slide or Bridge (default: the current version)."""
    if version not in (None, 0, 1) or (version == 0 and task not in CLASSES_V0):
        raise ValueError(f"{task}-varied has no version {version}")
    cls = CLASSES_V0[task] if version == 0 else CLASSES[task]
    if timestep is not None:
        cls = type(cls.__name__, (cls,), {"timestep": float(timestep)})
    return cls(with_panda=False, physics_space=physics_space)


def _geom(env, name: str) -> int:
    g = mujoco.mj_name2id(env.model, mujoco.mjtObj.mjOBJ_GEOM, name)
    if g < 0:
        raise KeyError(f"{env.task_name}: no geom {name!r}")
    return g


def _touching(env, g1: int, g2: int) -> bool:
    d = env.data
    return any({int(c.geom1), int(c.geom2)} == {g1, g2} for c in d.contact[:d.ncon])


def random_actions(env, rng: np.random.Generator, n: int) -> np.ndarray:
    lo, hi = env.action_space.low.astype(np.float64), env.action_space.high.astype(np.float64)
    return lo + (hi - lo) * rng.random((n, len(lo)))


# ============================================================================================== restitution
def measured_restitution(env, action, gravity: bool = True) -> float:
    """The restitution of the impact that ``action`` starts in the context ``env`` was reset to.

    Pendulum tasks: the relative speed of object and bob along the swing direction after the bob lets go, over the
    bob's speed at the first touch; Bounce: the ball's speed along the incline normal after / before. The contact is
    stepped until the pair separates. ``gravity=False``: gravity is off from the first touch to the separation.
    """
    action = np.asarray(action, dtype=np.float64)
    env.release(action)
    m, d = env.model, env.data
    if isinstance(env, BounceVariedEnv):
        yaw = float(action[0])
        n = np.array([math.cos(yaw), math.sin(yaw), 1.0]) / math.sqrt(2)
        pair = (_geom(env, "ball_geom"), _geom(env, "wedge_incline"))

        def approach() -> float:                     # the ball's speed along the incline normal
            return float(env.object_vel() @ n)
    else:
        u = np.array([math.cos(action[0]), math.sin(action[0]), 0.0])
        arm = assets.PENDULUM_LENGTH
        pair = (_geom(env, hp.BOB_COLLIDER), _geom(env, env.object_geom))

        def approach() -> float:                     # object minus bob speed along the swing direction
            return float(env.object_vel() @ u + env.pendulum.hinge_speed() * arm)
    before = approach()
    saved = m.opt.gravity.copy()
    if not gravity:
        m.opt.gravity[:] = 0.0
    try:
        for _ in range(int(0.2 / m.opt.timestep)):
            mujoco.mj_step(m, d)
            if not _touching(env, *pair):
                break
        else:
            raise RuntimeError(f"{env.task_name}: the impact of {action.tolist()} did not separate within 0.2 s")
    finally:
        m.opt.gravity[:] = saved
    return -approach() / before


def restitution_samples(task: str, seeds: list[int], space: str) -> np.ndarray:
    """``(len(seeds), 3)``: per sample the set restitution, the measured one and the one measured without gravity
    during the impact (contexts ``seeds`` in physics ``space``, actions from ``default_rng(seeds[0])``)."""
    env = make(task, physics_space=space)
    acts = random_actions(env, np.random.default_rng(seeds[0]), len(seeds))
    rows = []
    for s, a in zip(seeds, acts):
        env.reset(seed=s)
        e = env.hidden_physics["restitution"]
        got = measured_restitution(env, a)
        env.reset(seed=s)
        rows.append((e, got, measured_restitution(env, a, gravity=False)))
    env.close()
    return np.array(rows)


def restitution_summary(rows: np.ndarray) -> dict[str, float]:
    """Max and p90 of |measured - set| (with and without gravity), the mean signed error, the set value at the max."""
    err, err0 = rows[:, 1] - rows[:, 0], rows[:, 2] - rows[:, 0]
    worst = int(np.argmax(np.abs(err)))
    return {"n": len(rows), "max": float(np.abs(err).max()), "p90": float(np.percentile(np.abs(err), 90)),
            "mean": float(err.mean()), "e_at_max": float(rows[worst, 0]),
            "max_no_gravity": float(np.abs(err0).max()), "p90_no_gravity": float(np.percentile(np.abs(err0), 90))}


# ================================================================================================= friction
def surfaces(env) -> list[tuple[str, str, float, float]]:
    """(name, geom, window start, window end) of the surfaces the block slides on, the window in metres from the
    block's start along its path (Bridge: the start is the table's centre); a window also ends where the block's
    corners come within :data:`END_CLEARANCE` of its surface's edge. Slide has a second window on its table over
    the stretch of Bridge's round-table window (:data:`BRIDGE_TABLE_STRETCH`): the two tables compared like for like."""
    if isinstance(env, BridgeVariedEnv):
        rim = assets.BRIDGE_TABLE_RADIUS
        return [("table", "table_top", TABLE_START, rim),
                ("plank", "bridge_plank", rim + PLANK_START, rim + assets.BRIDGE_LENGTH)]
    return [("table", "table_top", TABLE_START, math.inf),
            ("table, Bridge's stretch", "table_top", *BRIDGE_TABLE_STRETCH)]


def _inside(env, geom: int, xy: np.ndarray, margin: float) -> bool:
    """Whether ``xy`` lies on the box ``geom``'s top at least ``margin`` inside its edges."""
    d = env.data
    local = d.geom_xmat[geom].reshape(3, 3).T @ (np.array([xy[0], xy[1], d.geom_xpos[geom][2]]) - d.geom_xpos[geom])
    return bool(np.all(np.abs(local[:2]) <= env.model.geom_size[geom][:2] - margin))


def rest_height(env, geom: int, r: float, phi: float) -> float:
    """The block's centre height resting on ``geom`` at distance ``r`` along ``phi`` from its start (settled for
    0.2 s on a scratch copy of the current state, everything else at rest)."""
    m = env.model
    d = mujoco.MjData(m)
    d.qpos[:] = env.data.qpos
    mujoco.mj_forward(m, d)
    top = d.geom_xpos[geom][2] + m.geom_size[geom][2]
    q = env.scene.object_qpos
    d.qpos[q:q + 3] = (env.object_start[0] + r * math.cos(phi), env.object_start[1] + r * math.sin(phi),
                       top + assets.PUCK_HALF_HEIGHT + 1e-4)
    d.qvel[:] = 0.0
    mujoco.mj_step(m, d, nstep=int(round(0.2 / m.opt.timestep)))
    return float(d.qpos[q + 2])


def slide_windows(env, action) -> dict[str, dict[str, float]]:
    """Per surface of the context ``env`` was reset to: the fitted friction (deceleration / g), the share of the
    window's steps with no contact between the block and the surface, the greatest height above the block's rest
    height on it (m) and the window's steps. A surface whose window the block does not fill is left out."""
    action = np.asarray(action, dtype=np.float64)
    phi = float(action[0])
    env.release(action)
    m, d = env.model, env.data
    qa, va = env.scene.object_qpos, env.scene.object_qvel
    block = _geom(env, env.object_geom)
    parts = [(name, _geom(env, geom), lo, hi) for name, geom, lo, hi in surfaces(env)]
    # rest heights: on the table 0.1 m behind the start (clear of the pad and the bob), on the plank at its window
    rest = {name: rest_height(env, g, -0.1 if name.startswith("table") else lo, phi) for name, g, lo, _ in parts}
    samples: dict[str, list[tuple[float, float, bool, float]]] = {name: [] for name, *_ in parts}
    start = env.object_start[:2]
    edge = BLOCK_HALF * math.sqrt(2) + END_CLEARANCE     # a window keeps the block's corners this far from an edge
    last = max(hi for *_, hi in parts)
    for k in range(int(assets.MAX_SIM_TIME / m.opt.timestep)):
        mujoco.mj_step(m, d)
        r = float(np.linalg.norm(d.qpos[qa:qa + 2] - start))
        speed = float(np.linalg.norm(d.qvel[va:va + 2]))
        if d.qpos[qa + 2] < env.object_start[2] - 0.01 or r > last or (speed < MIN_SPEED and r > TABLE_START):
            break                                          # off an edge, past the last window, or stopping
        for name, g, lo, hi in parts:
            if lo < r < hi and _inside(env, g, d.qpos[qa:qa + 2], edge):
                samples[name].append((k * m.opt.timestep, speed, _touching(env, block, g), d.qpos[qa + 2]))
    out = {}
    for name, rows in samples.items():
        if len(rows) < MIN_WINDOW_STEPS:
            continue
        a = np.array(rows, dtype=np.float64)
        out[name] = {"friction": float(-np.polyfit(a[:, 0], a[:, 1], 1)[0] / assets.GRAVITY),
                     "out_of_contact": float(1.0 - a[:, 2].mean()), "rise": float(a[:, 3].max() - rest[name]),
                     "steps": len(rows)}
    return out


def friction_samples(task: str, seeds: list[int], space: str) -> dict[str, np.ndarray]:
    """Per surface, ``(k, 4)`` rows (set friction, measured, out-of-contact share, rise m) over the samples whose block
    fills that surface's window: contexts ``seeds`` in ``space``; from ``default_rng(seeds[0])`` the swing direction
    phi, the release angle in :data:`SLIDE_THETA` and (Bridge) the plank's yaw = phi, so that the block slides
    along the plank."""
    env = make(task, physics_space=space)
    rng = np.random.default_rng(seeds[0])
    lo, hi = env.action_space.low.astype(np.float64), env.action_space.high.astype(np.float64)
    out: dict[str, list] = {name: [] for name, *_ in surfaces(env)}
    for s in seeds:
        phi, theta = rng.uniform(lo[0], hi[0]), rng.uniform(*SLIDE_THETA)
        env.reset(seed=s)
        mu = env.hidden_physics["friction"]
        action = [phi, theta] + [phi] * (len(lo) - 2)
        for name, w in slide_windows(env, action).items():
            out[name].append((mu, w["friction"], w["out_of_contact"], w["rise"]))
    env.close()
    return {name: np.array(rows, dtype=np.float64).reshape(-1, 4) for name, rows in out.items()}


def friction_summary(rows: np.ndarray) -> dict[str, float]:
    """Max and p90 of |measured - set| friction, median and max out-of-contact share, p90 and max rise (m)."""
    if len(rows) == 0:
        return {"n": 0}
    err = np.abs(rows[:, 1] - rows[:, 0])
    return {"n": len(rows), "max": float(err.max()), "p90": float(np.percentile(err, 90)),
            "out_median": float(np.median(rows[:, 2])), "out_max": float(rows[:, 2].max()),
            "rise_p90": float(np.percentile(rows[:, 3], 90)), "rise_max": float(rows[:, 3].max())}
