"""The hidden physics the pendulum tasks share: :class:`PendulumHidden` (bob mass and bob-object restitution; the
attempt starts at the bob's first touch of the object, the pendulum's frictionless swing integrated in closed form)
and :class:`PuckHidden` (plus the puck's table and plank friction; the puck starts on a frictionless launch pad)."""
from __future__ import annotations

import dataclasses
import math

import mujoco
import numpy as np

from .. import assets
from ..block import add_friction_pair
from ..description import Support
from ..tools.supports import polar_goal
from . import contacts as hc
from . import declaration as hp
from .component import ON_PAD, SETTLE_TIME, TOUCH_OVERLAP, HiddenPhysics


class PendulumHidden(HiddenPhysics):
    """Hidden bob mass and bob-object restitution; the attempt starts at the bob's first touch of the object (the
    pendulum's frictionless swing integrated in closed form). The bob collides through a sphere (its own body)."""

    def __init__(self, env, physics_space=None):
        super().__init__(env, physics_space)
        self._settled_qpos = None

    @classmethod
    def varied_attributes(cls, nominal):
        """The bob's sphere collider hits the object at its centre height."""
        return {"facts": dataclasses.replace(nominal.facts, bob_dz=0.0)}

    @property
    def rig(self):
        return self.env.pendulum

    @property
    def target(self):
        return self.env.pendulum.target

    @property
    def reach_origin(self) -> np.ndarray:
        return self.target.start[:2]

    @property
    def rest_half(self) -> float:
        """The object's half-size that the rig's rest pose clears (between attempts, while the object settles)."""
        return self.target.half

    def build(self, root) -> None:
        hc.separate_bob(root)
        hc.add_impact_pair(root, hc.BOB_COLLIDER, self.target.geom, "bob_object", hp.BOB_RESTITUTION.nominal,
                           hc.BOB_STIFFNESS)

    def set_hidden(self, values) -> None:
        # mj_setConst (in set_bob_mass) reads the model's current rig pose: put it in the fixed rest pose first, so
        # the derived constants do not depend on the previous attempt's aim (replay stays bit-identical)
        env = self.env
        self.rig.aim_at_target(self.rig.rest_phi, 0.0, self.rest_half)
        hc.set_bob_mass(env.model, env.data, values["bob_mass"])
        hc.set_restitution(env.model, "bob_object", values["restitution"], hc.BOB_STIFFNESS)

    def sample_goal(self, rng):
        return polar_goal(rng, self.reach_origin, self.goal_distance_range)

    def describe(self, description, actions) -> None:
        """The bob's mass and the bob-object restitution are hidden."""
        description.striker.bob_mass = "bob_mass"
        description.striker.restitution = "restitution"

    def launch_speed(self, values, theta: float) -> float:
        """Closed-form speed of the object after the hit at release angle ``theta`` (for the reach band)."""
        mgd, inertia = hc.pendulum_constants(self.env.model, bob_mass=values["bob_mass"])
        l = assets.PENDULUM_LENGTH
        v_bob = math.sqrt(2 * mgd * (1 - math.cos(theta)) / inertia) * l
        m_eff = inertia / l ** 2
        m2 = assets.PUCK_MASS if self.env.object_name == "puck" else assets.BALL_MASS
        return (1 + values["restitution"]) * m_eff / (m_eff + m2) * v_bob

    def settled(self) -> np.ndarray:
        """The object's pose after settling on its support for SETTLE_TIME (computed once, on a scratch state)."""
        if self._settled_qpos is None:
            env = self.env
            d = mujoco.MjData(env.model)
            a = env.scene.object_qpos
            d.qpos[a:a + 3] = self.target.start
            d.qpos[a + 3:a + 7] = (1, 0, 0, 0)
            mujoco.mj_step(env.model, d, nstep=int(round(SETTLE_TIME / env.timestep)))
            self._settled_qpos = d.qpos[a:a + 7].copy()
        return self._settled_qpos

    def after_apply(self, action) -> None:
        self.start_at_touch(float(action[0]), float(action[1]))

    def after_arm(self, action) -> None:
        """Robot mode: the arm has let go of the bob; its free swing to the first touch is integrated in closed form
        from the state the arm left it in (angle and speed, energy conservation), as in the kinematic mode, and the
        object, which the arm never touches, starts from its settled rest pose."""
        env = self.env
        theta, omega = self.rig.hinge_angle(), self.rig.hinge_speed()
        self.start_at_touch(float(action[0]), theta, omega)
        mujoco.mj_forward(env.model, env.data)

    def start_at_touch(self, phi: float, theta: float, omega: float = 0.0) -> None:
        """Object at its settled pose; bob exactly touching it at the speed of a free swing released at ``theta``
        (hinge angle) with hinge speed ``omega`` (0: from rest, the kinematic mode)."""
        env, rig = self.env, self.rig
        data, s = env.data, env.scene
        obj = self.settled()
        data.qpos[s.object_qpos:s.object_qpos + 7] = obj
        data.qvel[s.object_qvel:s.object_qvel + 6] = 0
        pivot = rig.pivot()
        u = np.array([math.cos(phi), math.sin(phi), 0.0])
        l = assets.PENDULUM_LENGTH
        reach = assets.BOB_HALF + self.target.half - TOUCH_OVERLAP
        horizontal = env.object_name == "puck"

        def gap(th: float) -> float:
            c = pivot + l * (-math.sin(th) * u + np.array([0.0, 0.0, -math.cos(th)]))
            r = c - obj[:3]
            return float(np.hypot(r[0], r[1]) if horizontal else np.linalg.norm(r)) - reach

        lo, hi = -0.2, 0.0                      # the bob touches just past the bottom: gap(lo) < 0 < gap(hi)
        for _ in range(80):
            mid = 0.5 * (lo + hi)
            lo, hi = (mid, hi) if gap(mid) < 0 else (lo, mid)
        touch = 0.5 * (lo + hi)
        data.qpos[rig.hinge] = touch
        if omega == 0.0:
            data.qvel[rig.hinge_dof] = -hc.swing_speed(env.model, theta, touch)
        else:
            mgd, inertia = hc.pendulum_constants(env.model)
            w2 = omega * omega + 2.0 * mgd * (math.cos(touch) - math.cos(theta)) / inertia
            data.qvel[rig.hinge_dof] = -math.sqrt(max(0.0, w2))


class PuckHidden(PendulumHidden):
    """The puck tasks: hidden table (and plank) friction too; the puck starts on the frictionless launch pad.

    The block puck (the v1 ids) sits on a square pad, both turned to the swing plane ``phi`` at the first touch
    (in robot mode before the arm moves: the scene turns them, not the arm), its friction pairs with the slow
    friction reference; the closed forms below are unchanged (the block leaves the pad ``PAD_RADIUS`` along its
    path, as the disc does). The v0 ids: the disc on the round pad.
    """

    friction_geoms: tuple[tuple[str, str], ...] = (("table_top", "object_table"),)

    @classmethod
    def varied_attributes(cls, nominal):
        """Also: the table's nominal friction is the hidden parameter's, and the puck starts on its pad."""
        return {"facts": dataclasses.replace(nominal.facts, bob_dz=0.0, table_friction=hp.FRICTION.nominal),
                "object_start": nominal.object_start + ON_PAD}

    @property
    def block(self) -> bool:
        return self.target.block

    def adapt(self, tools) -> None:
        """The puck's friction and turning are the hidden physics': its nominal pairs go, it no longer faces the
        swing plane at rest (:meth:`start_at_touch` turns it), and the pad turns with it."""
        puck = self.target
        puck.friction_pairs, puck.faces = (), False
        if puck.block:
            puck.supports = (hc.PAD_BODY,) + puck.supports

    def build(self, root) -> None:
        super().build(root)
        hc.add_launch_pad(root, self.target.start[:2], assets.TABLE_HEIGHT, square=self.block)
        for geom, pair in self.friction_geoms:
            add_friction_pair(root, self.target.geom, geom, pair, hp.FRICTION.nominal, soft_reference=self.block)

    def set_hidden(self, values) -> None:
        super().set_hidden(values)
        for _, pair in self.friction_geoms:
            hc.set_friction(self.env.model, pair, values["friction"])

    @property
    def rest_half(self) -> float:
        # the block's corner (at yaw 0, while it settles) reaches sqrt(2) times its half edge
        return self.target.half * math.sqrt(2) if self.block else self.target.half

    def reset_scene(self, context, reset_tools) -> None:
        if self.block:
            self.target.turn_supports(0.0)   # neutral between attempts: a reset does not depend on history
        super().reset_scene(context, reset_tools)
        if self.block:                       # the resting rig clears the (unturned) block's corners
            self.rig.aim_at_target(self.rig.rest_phi, 0.0, self.rest_half)

    def settled(self) -> np.ndarray:
        if self.block and self._settled_qpos is None:
            # settle at a fixed yaw with the rig at its rest pose clear of the block's corners (the caller has aimed
            # it at this attempt's swing plane): the pose depends on neither the first aim nor the history
            m, rig = self.env.model, self.rig
            pose = (m.body_pos[rig.rig].copy(), m.body_quat[rig.rig].copy(), self.env.data.qpos[rig.hinge])
            self.target.turn_supports(0.0)
            rig.aim_at_target(rig.rest_phi, 0.0, self.rest_half)
            settled = super().settled()
            m.body_pos[rig.rig], m.body_quat[rig.rig] = pose[0], pose[1]
            self.env.data.qpos[rig.hinge] = pose[2]
            return settled
        return super().settled()

    def start_at_touch(self, phi: float, theta: float, omega: float = 0.0) -> None:
        super().start_at_touch(phi, theta, omega)
        if self.block:
            self.target.face_swing_plane(phi, from_start=False)

    def before_arm(self, action) -> None:
        if self.block:        # robot mode: the scene turns block and pad before the arm moves
            self.target.face_swing_plane(float(action[0]), from_start=False)

    def describe(self, description, actions) -> None:
        """Also: the friction of every top the puck slides on is hidden, and it starts on its frictionless pad (the
        square one turned to the swing plane ``phi``)."""
        super().describe(description, actions)
        for support in description.supports:
            if support.friction != 0:
                support.friction = "friction"
        start = self.target.start
        if self.block:
            pad = Support(hc.PAD_BODY, "rect", start[:2].copy(), start[2] - assets.PUCK_HALF_HEIGHT, 0.0,
                          half=np.full(2, hc.PAD_RADIUS), yaw=np.asarray(actions[:, 0], dtype=np.float64).copy())
        else:
            pad = Support("launch_pad", "disc", start[:2].copy(), start[2] - assets.PUCK_HALF_HEIGHT, 0.0,
                          radius=hc.PAD_RADIUS)
        description.supports.insert(0, pad)

    def stop_distance(self, values, theta: float) -> float:
        """Closed form: frictionless across the pad, then v^2 / (2 mu g)."""
        v = self.launch_speed(values, theta)
        return hc.PAD_RADIUS + v * v / (2 * values["friction"] * assets.GRAVITY)
