"""The hit skill's scene: the task pendulum hitting the ball on the pedestal (Launch) or the puck on the table
(Slide), with the bob mass and the object mass varied: ``(m1, m2, v_init) -> (v,)``.

``v`` is the *outcome-equivalent launch speed*: MuJoCo's bob contact is soft and lasts 50-80 ms, during which the
object travels 5-15 cm with the bob, so the object's speed when it separates from the bob does not predict where it
goes. The recorded ``v`` is the speed that an instantaneous hit at the object's resting position would need to give
the same outcome: for the ball, the landing distance at the Launch task's landing height divided by the ideal fall
time from the pedestal top; for the puck, ``sqrt(2 mu g D)`` with D the distance from its start to where it stops
and mu the deceleration measured on the same table (:func:`.slide.measured_slide_mu`). ``v_init`` is the bob's
speed measured at the first bob-object contact. The physical separation speed is kept in ``extras``.
"""
from __future__ import annotations

import math

import mujoco
import numpy as np

from .. import assets
from ..tasks.launch import FACTS as LAUNCH_FACTS
from ..tasks.slide import FACTS as SLIDE_FACTS
from ..tools import Pendulum
from .common import DataSpec, Scene, progress, steps
from .slide import measured_slide_mu
from .swing import pendulum_equivalent_length

# Hit: bob masses around the task's 0.5 kg; object masses around the ball (0.1 kg, on the pedestal) and the puck
# (0.05 kg, on the table), in two separate ranges (the two objects differ in shape and support, not only mass).
HIT_M1 = (0.4, 0.6)
HIT_M2_BALL = (0.08, 0.14)
HIT_M2_PUCK = (0.03, 0.065)
HIT_V = (1.0, 2.7)        # bob speed at impact: the tasks' theta range gives 1.31-2.43 m/s
HIT_PHI = (0.0, math.pi / 2)

DATA = DataSpec("hit", ("m1", "m2", "v_init"), ("v",), ("kg", "kg", "m/s"), ("m/s",),
                (HIT_M1, (HIT_M2_PUCK[0], HIT_M2_BALL[1]), HIT_V),
                "the pendulum bob (m1) hitting the ball (m2 in HIT_M2_BALL) or the puck (m2 in HIT_M2_PUCK)")


class HitScene:
    """The pendulum rig aimed at the ball on the pedestal (Launch) or at the puck on the table (Slide)."""

    def __init__(self, obj: str):
        root = assets.arena(f"skill_hit_{obj}")
        if obj == "ball":
            f = LAUNCH_FACTS
            start = np.array(f.ball_start)
            assets.add_pedestal(root, start[:2])
            assets.add_ball(root)
            self.start, self.half, self.bob_dz = start, f.ball_radius, f.bob_dz
            self.landing_height = f.landing_height
        else:
            f = SLIDE_FACTS
            assets.add_table(root, -0.3, 2.8, -0.3, 2.8, height=f.table_height, friction=f.table_friction)
            assets.add_puck(root)
            self.start, self.half, self.bob_dz = np.array(f.puck_start), f.puck_radius, f.bob_dz
        assets.add_pendulum(root)
        self.obj = obj
        self.spec = mujoco.MjSpec.from_string(root.to_xml_string(), assets=root.get_assets())

    def prepared(self, m1: float, m2: float, theta: float, phi: float) -> tuple[Scene, int, int, int, int, int]:
        """A fresh scene with the masses set, the object at rest at its start and the pendulum released at ``theta``
        in the plane ``phi``: ``(scene, object qpos address, object dof address, hinge dof address, bob geom,
        object geom)``."""
        self.spec.geom("pendulum_bob").mass = m1
        self.spec.geom(f"{self.obj}_geom").mass = m2
        s = Scene(self.spec.compile())
        q = s.joint_qpos_adr(f"{self.obj}_free")
        s.data.qpos[q:q + 3] = self.start
        s.data.qpos[q + 3:q + 7] = (1, 0, 0, 0)
        Pendulum(s).aim(self.start, phi, theta, self.half, self.bob_dz)
        mujoco.mj_forward(s.model, s.data)
        return (s, q, s.joint_dof_adr(f"{self.obj}_free"), s.joint_dof_adr("pendulum_hinge"),
                s.geom_id("pendulum_bob"), s.geom_id(f"{self.obj}_geom"))

    def run(self, m1: float, m2: float, theta: float, phi: float) -> dict[str, float]:
        s, q, dv, hv, bob, obj = self.prepared(m1, m2, theta, phi)
        m, d = s.model, s.data
        u = np.array([math.cos(phi), math.sin(phi)])
        max_steps = steps(assets.MAX_SIM_TIME)
        v_bob = None
        contact_end = None
        v_sep = None
        prev = d.qpos[q:q + 3].copy()
        out = None
        for k in range(max_steps):
            w = d.qvel[hv]
            mujoco.mj_step(m, d)
            touching = s.touching(bob, obj)
            if v_bob is None:
                if touching:
                    v_bob = abs(w) * assets.PENDULUM_LENGTH
                    k_first = k
                continue
            if touching:
                contact_end = None
                continue
            if contact_end is None:
                contact_end = k
                v_sep = float(d.qvel[dv:dv + 2] @ u)
            pos = d.qpos[q:q + 3].copy()
            if self.obj == "ball":
                z_land = self.landing_height
                if pos[2] <= z_land < prev[2]:
                    f = (prev[2] - z_land) / (prev[2] - pos[2])
                    land = prev + f * (pos - prev)
                    reach = float((land[:2] - self.start[:2]) @ u)
                    fall = math.sqrt(2.0 * (self.start[2] - z_land) / assets.GRAVITY)
                    out = {"v": reach / fall, "distance": reach}
                    break
            elif k - contact_end > 20:
                vel = d.qvel[dv:dv + 3]
                if vel @ vel < 0.01 ** 2:
                    dist = float((pos[:2] - self.start[:2]) @ u)
                    out = {"v": math.sqrt(2.0 * measured_slide_mu() * assets.GRAVITY * max(dist, 0.0)),
                           "distance": dist}
                    break
            prev = pos
        if v_bob is None or out is None:
            raise RuntimeError(f"hit scene ({self.obj}, m1={m1}, m2={m2}, theta={theta}, phi={phi}): the "
                               f"{'bob never touched the object' if v_bob is None else 'object did not land/stop'}")
        out.update(v_bob=v_bob, v_sep=v_sep, contact_s=(contact_end - k_first) * m.opt.timestep)
        return out


def generate_samples(n: int, rng: np.random.Generator, show: bool, v_range=HIT_V,
                     label: str = "hit") -> tuple[np.ndarray, np.ndarray, dict]:
    """``n`` hits: object (ball or puck), masses, bob speed (in ``v_range``) and hit direction drawn uniformly."""
    scenes = {"ball": HitScene("ball"), "puck": HitScene("puck")}
    l_eq = pendulum_equivalent_length()
    x = np.empty((n, 3))
    y = np.empty((n, 1))
    ex = {k: np.empty(n) for k in ("is_puck", "v_sep", "distance", "contact_s", "theta", "phi")}
    for i in progress(n, f"{label} data", show):
        obj = "puck" if rng.random() < 0.5 else "ball"
        m1 = rng.uniform(*HIT_M1)
        m2 = rng.uniform(*(HIT_M2_PUCK if obj == "puck" else HIT_M2_BALL))
        v_target = rng.uniform(*v_range)
        phi = rng.uniform(*HIT_PHI)
        # release angle whose ideal bottom speed is v_target; the recorded v_init is the measured bob speed
        theta = math.acos(1.0 - v_target ** 2 / (2.0 * assets.GRAVITY * l_eq))
        r = scenes[obj].run(m1, m2, theta, phi)
        x[i] = (m1, m2, r["v_bob"])
        y[i] = (r["v"],)
        for k, val in (("is_puck", float(obj == "puck")), ("v_sep", r["v_sep"]), ("distance", r["distance"]),
                       ("contact_s", r["contact_s"]), ("theta", theta), ("phi", phi)):
            ex[k][i] = val
    return x, y, ex
