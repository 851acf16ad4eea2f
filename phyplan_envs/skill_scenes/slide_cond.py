"""The friction-conditioned slide skill's scene: the puck sliding under the varied tasks' physics,
``(friction, v_init, t) -> (x, v)``.

The hidden-physics track (:mod:`phyplan_envs.hidden_physics`) sets the puck-table friction per context through a
contact pair; this scene is the puck on a long strip of table with that pair, at the varied timestep, and records
the sliding phase of a launch at ``v_init`` for a friction value drawn from the **training space** only. The data
spec's friction range is the hull of the training and test spaces: the domain of the models' normalisation and of
the PINN's physics (collocation) points, so the friction-conditioned PINN's equation ``x'' = -friction g`` carries it
beyond the friction values it saw data for.

Each launch is sampled at ``TIMES_PER_LAUNCH`` uniform times of its sliding phase (rows ``k * TIMES_PER_LAUNCH``
to ``k * TIMES_PER_LAUNCH + TIMES_PER_LAUNCH - 1`` share launch k), which cuts the simulation cost per row.
"""
from __future__ import annotations

import math

import mujoco
import numpy as np

from .. import assets
from ..block import add_friction_pair, make_block
from .. import hidden_physics as hp
from ..hidden_physics import TIMESTEP
from ..tasks.slide import FACTS as SLIDE_FACTS
from .common import DataSpec, Scene, progress
from .hit_cond import draw_train
from .slide import slide_rollout

PARAM = hp.FRICTION
FRICTION_HULL = (0.15, 0.6)   # the hull of the training and test spaces (fixed: the shipped model's domain)
SLIDE_COND_V = (0.5, 4.5)    # m/s: puck speeds over the test space (fast bob hits reach ~4.3 m/s)
# the longest slide of the domain (slowest friction, fastest puck) with 5 % margin
SLIDE_COND_T = (0.0, round(1.05 * SLIDE_COND_V[1] / (FRICTION_HULL[0] * assets.GRAVITY), 2))
TIMES_PER_LAUNCH = 4
STRIP_LENGTH = 5.0           # m: the longest slide of the training space is 4.1 m

DATA = DataSpec("slide_cond", ("friction", "v_init", "t"), ("x", "v"), ("", "m/s", "s"), ("m", "m/s"),
                (FRICTION_HULL, SLIDE_COND_V, SLIDE_COND_T),
                "the puck sliding on the varied table (friction pair), sliding phase only; friction data from the "
                "training space")


def slide_cond_scene() -> tuple[Scene, np.ndarray]:
    """The puck settled on a long table strip with the varied friction pair; returns the scene and its state."""
    root = assets.arena("skill_slide_cond")
    root.option.timestep = TIMESTEP
    assets.add_table(root, -0.3, STRIP_LENGTH, -0.4, 0.4, height=SLIDE_FACTS.table_height)
    assets.add_puck(root, mass=SLIDE_FACTS.puck_mass)
    make_block(root)                          # the v1 varied tasks' block (launched along a face normal, +x)
    add_friction_pair(root, "puck_geom", "table_top", "object_table", PARAM.nominal, soft_reference=True)
    s = Scene.from_root(root)
    m, d = s.model, s.data
    q = s.joint_qpos_adr("puck_free")
    d.qpos[q:q + 3] = (0.0, 0.0, SLIDE_FACTS.puck_start[2])
    d.qpos[q + 3:q + 7] = (1, 0, 0, 0)
    mujoco.mj_step(m, d, nstep=int(round(0.3 / m.opt.timestep)))   # settle into the contact
    d.qvel[:] = 0
    state = np.zeros(mujoco.mj_stateSize(m, mujoco.mjtState.mjSTATE_INTEGRATION))
    mujoco.mj_getState(m, d, state, mujoco.mjtState.mjSTATE_INTEGRATION)
    return s, state


def slide_cond_rollout(s: Scene, state: np.ndarray, friction: float, v0: float) -> tuple[np.ndarray, np.ndarray]:
    """Launch the settled puck at ``v0`` along +x with the given friction; (x, v) every step of the sliding phase."""
    hp.set_friction(s.model, "object_table", friction)
    xs, vs = slide_rollout(s, state, v0, SLIDE_COND_T[1])
    k = len(xs) - 1
    if xs[k] > STRIP_LENGTH - 0.1:
        raise RuntimeError(f"slide_cond scene: the puck (friction {friction}, v0 {v0}) slid off the strip")
    return xs[:k + 1], vs[:k + 1]


def generate_samples(n: int, rng: np.random.Generator, show: bool) -> tuple[np.ndarray, np.ndarray, dict]:
    """``n`` rows: friction (training space) and launch speed per launch, ``TIMES_PER_LAUNCH`` times per launch."""
    s, state = slide_cond_scene()
    dt = s.model.opt.timestep
    x = np.empty((n, 3))
    y = np.empty((n, 2))
    launches = math.ceil(n / TIMES_PER_LAUNCH)
    i = 0
    for _ in progress(launches, "slide_cond data", show):
        mu = draw_train(PARAM, rng)
        v0 = rng.uniform(*SLIDE_COND_V)
        u = rng.random(TIMES_PER_LAUNCH)
        xs, vs = slide_cond_rollout(s, state, mu, v0)
        for f in u:
            if i == n:
                break
            k = min(int(f * len(xs)), len(xs) - 1)
            x[i] = (mu, v0, k * dt)
            y[i] = (xs[k], vs[k])
            i += 1
    return x, y, {}
