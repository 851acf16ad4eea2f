"""The low-restitution general-incidence bounce skills for the Paddles task: ``bounce_general_low`` (nominal
contact) and ``bounce_general_low_cond`` (the hidden-physics track's impact pair), both at the Paddles timestep
(0.5 ms), ``(e, incline_angle, v_down, v_across, v_normal) -> (v_down, v_across, v_normal)`` in the incline frame of
:mod:`.bounce_general` (same inputs, outputs, frame and arrival procedure; new data specs, the shipped
``bounce_general`` skills are unchanged).

* ``bounce_general_low``: the paddle's contact (``priority=1``, ``condim=1``, zero friction) with ``solref =
  solref_for_restitution(e, 2e5)`` (:mod:`phyplan_envs.contact`; the Paddles paddle is e = 0.1 with
  ``assets.PADDLE_STIFFNESS`` = 2e5), ``e`` uniform in :data:`E_LOW` (0.03-0.45).
* ``bounce_general_low_cond``: the impact pair of :func:`.bounce_cond.bounce_cond_scene` (calibrated damping,
  constant impedance, :func:`phyplan_envs.hidden_physics.set_restitution` with ``INCLINE_STIFFNESS``), restitution
  data from ``PADDLE_RESTITUTION``'s training space (0.05-0.25), model domain its hull (0.02-0.4).

Domain: speed uniform in :data:`SPEED_LOW` (0.5-9 m/s: a fall of 1 m between paddles plus the glide), direction
within 85 degrees of the inward normal and at least 0.1 m/s towards the face (:func:`.bounce_general.draw_velocity`),
incline angle 10-80 degrees.

**End of the contact at low restitution.** :meth:`.bounce_general.GeneralBounceScene.bounce` records the velocity
at the first state out of contact. With a low restitution the ball often never leaves the face: it rebounds
at ``~e |v_normal|`` (3 mm/s for e = 0.03 at 0.1 m/s) and gravity's normal component (up to 9.7 m/s^2) stops that
within a millisecond, so it stays in resting contact and glides. Here ``v_out`` is therefore the velocity

* at the first state out of contact, if the ball separates (as ``bounce_general``), else
* at the **peak of the rebound**: the state of largest outward normal velocity after the deepest point of the
  contact, when the ball's normal velocity falls back to zero while it is still in contact, or when it is still in
  contact :data:`MAX_CONTACT_S` (30 ms) after the touch (the rebound is over and the ball stays on the face; the
  glide skill continues from there). Without the 30 ms cap a few arrivals at e <= 0.05 under the impact pair creep
  off the face at a tiny outward speed after up to 150 ms of gliding, and their ``v_down`` would carry that glide.
  The training and validation sets never reach the cap (their contacts last at most 15.5 ms).

``extras["separated"]`` is 1 for the first case, 0 for the second (docs/skills.md gives the fractions). The board
is 2 m square (the shipped scenes' 0.4 m x 0.3 m box could be left at 9 m/s during a long low-restitution contact),
so the contact never ends at an edge.
"""
from __future__ import annotations

import math

import mujoco
import numpy as np

from .. import assets
from .. import hidden_physics as hp
from ..contact import solref_for_restitution
from .bounce_general import ANGLE, COLUMNS, MAX_INCIDENCE, MIN_NORMAL_SPEED, draw_velocity, incline_basis
from .common import DataSpec, Scene, progress

TIMESTEP = 0.0005                      # s: the Paddles task's
SPEED_LOW = (0.5, 9.0)                 # m/s
E_LOW = (0.03, 0.45)                   # nominal restitution of the solref (the Paddles paddle: 0.1)
STIFFNESS = 2.0e5                      # K of the nominal solref (bounce_general's; assets.PADDLE_STIFFNESS)
COND_PARAM = hp.PADDLE_RESTITUTION     # train (0.05, 0.25), test (0.02, 0.05) U (0.25, 0.4), nominal 0.1
COND_DOMAIN = COND_PARAM.hull()        # (0.02, 0.4): the conditioned model's domain
BOARD_HALF = (1.0, 1.0, assets.PADDLE_THICK / 2)
POINT = np.array([0.0, 0.0, 2.0])      # the impact point (the centre of the board's face)
PHYSICS = ("nominal", "varied")
SKILL_OF_PHYSICS = {"nominal": "bounce_general_low", "varied": "bounce_general_low_cond"}
WINDOW_S = 0.2                         # s: the longest a bounce is followed
MAX_CONTACT_S = 0.03                   # s: a ball still on the face this long after the touch has stopped bouncing
_V_RANGE = (-SPEED_LOW[1], SPEED_LOW[1])
_VN_RANGE = (-SPEED_LOW[1], -MIN_NORMAL_SPEED)

DATA = DataSpec("bounce_general_low", ("e", "incline_angle") + COLUMNS, COLUMNS,
                ("", "rad", "m/s", "m/s", "m/s"), ("m/s", "m/s", "m/s"),
                (E_LOW, ANGLE, _V_RANGE, _V_RANGE, _VN_RANGE),
                "the ball arriving at a frictionless low-restitution incline from any direction into its face (the "
                "paddle contact with solref_for_restitution(e, 2e5), timestep 0.5 ms); velocities in the incline "
                "frame; v_out at separation or at the rebound's peak when the ball stays on the face")
DATA_COND = DataSpec("bounce_general_low_cond", ("restitution", "incline_angle") + COLUMNS, COLUMNS,
                     ("", "rad", "m/s", "m/s", "m/s"), ("m/s", "m/s", "m/s"),
                     (COND_DOMAIN, ANGLE, _V_RANGE, _V_RANGE, _VN_RANGE),
                     "the ball arriving at a frictionless low-restitution incline (the varied impact pair, timestep "
                     "0.5 ms) from any direction into its face; restitution data from PADDLE_RESTITUTION's training "
                     "space; velocities in the incline frame; v_out at separation or at the rebound's peak")


def low_bounce_scene(physics: str) -> Scene:
    """The ball and a 2 m square board with the paddle's contact settings at 0.5 ms; ``"varied"`` adds the impact
    pair ``ball_incline`` (which overrides the geom's solref)."""
    if physics not in PHYSICS:
        raise ValueError(f"physics must be one of {PHYSICS}, got {physics!r}")
    root = assets.arena(f"skill_bounce_low_{physics}")
    root.option.timestep = TIMESTEP
    body = root.worldbody.add("body", name="incline", pos=POINT)
    body.add("geom", name="incline", type="box", size=BOARD_HALF, pos=(0, 0, -BOARD_HALF[2]),
             rgba=assets.TOOL_RGBA, priority=1, condim=1, friction=(0, 0, 0),
             solref=[float(v) for v in solref_for_restitution(COND_PARAM.nominal, STIFFNESS)],   # set per arrival
             **assets.WORLD)
    assets.add_ball(root)
    if physics == "varied":
        hp.add_impact_pair(root, "ball_geom", "incline", "ball_incline", COND_PARAM.nominal, hp.INCLINE_STIFFNESS)
    return Scene.from_root(root)


def start_arrival(m, d, qpos: int, dof: int, angle: float, v_local, phase: float) -> np.ndarray:
    """Put the ball (free joint at ``qpos``, ``dof``) one step before its touch of the face at :data:`POINT`, tilted
    by ``angle``, so that it arrives with velocity ``v_local`` (incline frame, into the face) at phase ``phase`` of
    that step (the procedure of :meth:`.bounce_general.GeneralBounceScene.bounce`); the incline frame's rows (down,
    across, normal). ``v_local`` and ``phase`` are checked: a ValueError names the one that is wrong."""
    v_local = np.asarray(v_local, dtype=float)
    if v_local.shape != (3,) or not np.all(np.isfinite(v_local)) or v_local[2] >= 0:
        raise ValueError(f"v_local must be 3 finite numbers with v_local[2] < 0 (into the face), got {v_local!r}")
    if not 0.0 < phase < 1.0:
        raise ValueError(f"phase must be in (0, 1), got {phase!r}")
    basis = incline_basis(angle)
    dt = float(m.opt.timestep)
    v1 = basis.T @ v_local
    v0 = v1 - m.opt.gravity * dt
    q1 = POINT + (assets.BALL_RADIUS - phase * abs(v_local[2]) * dt) * basis[2]
    mujoco.mj_resetData(m, d)
    d.qpos[qpos:qpos + 7] = (*(q1 - v1 * dt), 1.0, 0.0, 0.0, 0.0)
    d.qvel[dof:dof + 3] = v0
    mujoco.mj_forward(m, d)
    return basis


class LowBounceScene:
    """One physics' low-restitution bounce scene (compiled once; angle and restitution set per bounce)."""

    def __init__(self, physics: str = "nominal", stiffness: float | None = None):
        self.physics = physics
        self.stiffness = hp.INCLINE_STIFFNESS if stiffness is None else float(stiffness)   # K of the varied pair
        if not self.stiffness > 0:
            raise ValueError(f"stiffness must be > 0, got {stiffness!r}")
        self.scene = low_bounce_scene(physics)
        s = self.scene
        self.incline = s.geom_id("incline")
        self.qpos = s.joint_qpos_adr("ball_free")
        self.dof = s.joint_dof_adr("ball_free")

    def set_incline(self, e: float, angle: float) -> None:
        m = self.scene.model
        m.body_quat[m.geom_bodyid[self.incline]] = (math.cos(angle / 2), 0.0, math.sin(angle / 2), 0.0)
        if self.physics == "nominal":
            m.geom_solref[self.incline] = solref_for_restitution(e, STIFFNESS)
        else:
            hp.set_restitution(m, "ball_incline", e, self.stiffness)

    def bounce(self, e: float, angle: float, v_local, phase: float) -> dict:
        """One arrival (the procedure of :meth:`.bounce_general.GeneralBounceScene.bounce`: started one step before
        the touch, arrival phase ``phase``). Returns ``v_in``, ``v_out`` (incline frame), ``contact_s`` (from the
        first contact state to the recorded one) and ``separated``."""
        s = self.scene
        m, d = s.model, s.data
        self.set_incline(e, angle)
        basis = start_arrival(m, d, self.qpos, self.dof, angle, v_local, phase)
        normal = basis[2]
        dt = float(m.opt.timestep)
        if d.ncon:
            raise RuntimeError("low bounce scene: the ball starts in contact")
        v_in = v_out = None
        k_in = k_out = 0
        peak, k_peak = None, 0
        separated = False
        for k in range(int(round(WINDOW_S / dt))):
            before = d.qvel[self.dof:self.dof + 3].copy()
            mujoco.mj_step(m, d)
            # after mj_step, d.ncon holds the contacts of the state the step started from
            if v_in is None:
                if d.ncon:
                    v_in, k_in = before, k
                elif k > 0:
                    break
                continue
            if not d.ncon:                                    # out of contact: separated
                v_out, k_out, separated = before, k, True
                break
            vn = before @ normal
            if vn > 0 and (peak is None or vn > peak @ normal):
                peak, k_peak = before, k
            elif peak is not None and (vn <= 0 or (k - k_in) * dt >= MAX_CONTACT_S):
                # fell back onto the face, or still creeping on it: the rebound is over
                v_out, k_out = peak, k_peak
                break
        if v_in is None or v_out is None or v_out @ normal <= 0:
            raise RuntimeError(f"low bounce scene ({self.physics}, e={e}, angle={angle}, v={v_local.tolist()}, "
                               f"phase={phase}): no rebound within {WINDOW_S} s")
        return {"v_in": basis @ v_in, "v_out": basis @ v_out, "contact_s": (k_out - k_in) * dt,
                "separated": separated}


def sample(n: int, rng: np.random.Generator, physics: str, restitution=None, show: bool = False):
    """``n`` seeded arrivals (per sample from ``rng``: restitution, angle, velocity, phase, as
    :func:`.bounce_general.sample`). Returns inputs (N, 5), outputs (N, 3) and extras ``contact_s``,
    ``separated``, ``phase``."""
    scene = LowBounceScene(physics)
    if restitution is None:
        restitution = E_LOW if physics == "nominal" else COND_PARAM.train
    x, y = np.empty((n, 5)), np.empty((n, 3))
    ex = {k: np.empty(n) for k in ("contact_s", "separated", "phase")}
    for i in progress(n, f"{SKILL_OF_PHYSICS[physics]} data", show):
        e = float(restitution) if np.isscalar(restitution) else float(rng.uniform(*restitution))
        a = float(rng.uniform(*ANGLE))
        v = draw_velocity(rng, SPEED_LOW)
        u = min(max(rng.random(), 1e-3), 1.0 - 1e-3)
        r = scene.bounce(e, a, v, u)
        x[i] = (e, a, *r["v_in"])
        y[i] = r["v_out"]
        ex["contact_s"][i], ex["separated"][i], ex["phase"][i] = r["contact_s"], float(r["separated"]), u
    return x, y, ex


class _Low:
    DATA = DATA

    @staticmethod
    def generate_samples(n: int, rng: np.random.Generator, show: bool):
        return sample(n, rng, "nominal", show=show)


class _LowCond:
    DATA = DATA_COND

    @staticmethod
    def generate_samples(n: int, rng: np.random.Generator, show: bool):
        return sample(n, rng, "varied", show=show)


LOW, LOW_COND = _Low, _LowCond
__all__ = ["COND_DOMAIN", "COND_PARAM", "DATA", "DATA_COND", "E_LOW", "LOW", "LOW_COND", "LowBounceScene",
           "MAX_INCIDENCE", "SPEED_LOW", "TIMESTEP", "low_bounce_scene", "sample"]
