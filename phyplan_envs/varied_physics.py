"""The env machinery of the hidden-physics track (the varied tasks of :mod:`phyplan_envs.tasks.varied`).

:class:`VariedPhysicsMixin` adds hidden physics to a nominal task class: per-context values drawn from the train or
test space (:mod:`phyplan_envs.hidden_physics`) behind a sealed ``physics_token``, goals redrawn until reachable,
the privileged ``hidden_physics`` accessor and the ``physics`` reset option. :class:`PendulumVariedMixin` (bob mass and
bob-object restitution, the attempt starting at the bob's first touch) and :class:`PuckVariedMixin` (plus table and
plank friction, the puck on its launch pad) are the parts the pendulum tasks share.
"""
from __future__ import annotations

import math
from typing import Any, Mapping

import numpy as np

from . import assets
from .block import add_friction_pair, make_block, turn_body, turn_free_body
from . import hidden_physics as hp
from .base import PhyPlanEnv, polar
from .spaces import _process_secret, check_reset_options, short_repr

TIMESTEP = 0.0005          # s (the nominal tasks: 0.001)
REACH_MARGIN = 0.03        # the reach band is shrunk by this fraction at each end before goals are drawn
MIN_GOAL_BAND = 0.03       # m: narrower overlaps of reach band and goal region redraw the physics
TOUCH_OVERLAP = 1e-9       # m: the bodies start this far inside each other, so the contact is active at step 1
SETTLE_TIME = 0.3          # s: the object settles on its support before the first touch (as during a swing)


class VariedPhysicsMixin:
    """Hidden physics for a nominal task class (put first in the bases: ``class X(VariedPhysicsMixin, TaskEnv)``).

    Args (besides the nominal task's):
        physics_space: ``"auto"`` (default: ``reset(seed=s)`` with s in the test split draws from the test space,
            other seeds from the train space; an unseeded reset keeps the last seeded reset's space), ``"train"`` or
            ``"test"``.

    Reset options (besides the nominal ones): ``physics``: a dict of all hidden values to use instead of the
    context's (privileged: data generation and analysis; the harness never passes it).

    The context is ``{"goal", "physics_token"}``: the token seals the context's physics key and space under the
    secret the env took from its process at construction (:data:`phyplan_envs.spaces.SECRET_ENV`), so only an env
    holding that secret replays it (in this process or a child that inherited the variable; any other raises).
    """

    base_task: str = ""
    timestep: float = TIMESTEP      # a subclass may halve it (the timestep-convergence check does)
    reset_options = PhyPlanEnv.reset_options + ("physics",)
    context_keys = ("goal", "physics_token")
    reach_origin = np.zeros(2)

    def __init__(self, *args, physics_space: str = "auto", **kwargs):
        if not isinstance(physics_space, str):
            raise TypeError(f"physics_space must be 'auto', 'train' or 'test', got {type(physics_space).__name__} "
                            f"{short_repr(physics_space)}")
        if physics_space != "auto":
            hp.check_space(physics_space)
        self.physics_space = physics_space
        self._seed_space = "train"
        self._hidden: dict[str, float] | None = None
        self._override: dict[str, float] | None = None
        self._physics_secret = _process_secret()
        self.chunk = max(1, int(round(0.005 / self.timestep)))   # end-rule checks every 5 ms, as the nominal tasks
        super().__init__(*args, **kwargs)

    # --- privileged --------------------------------------------------------------------------------------------
    @property
    def hidden_physics(self) -> dict[str, float]:
        """The current context's hidden values: the one privileged accessor, for the harness's reports, diagnostics,
        design checks and tests, never for an agent (an agent in this process can read it, as any memory: the
        guarantee is that the context, the observation, ``info`` and the public functions do not give it away;
        docs/hidden-physics.md, *Threat model*)."""
        if self._hidden is None:
            raise RuntimeError("call reset() before reading hidden_physics")
        return dict(self._hidden)

    @property
    def hidden_parameters(self) -> tuple[hp.HiddenParameter, ...]:
        return hp.parameters(self.base_task)

    # --- the env hooks -------------------------------------------------------------------------------------------
    def build_scene(self, root) -> None:
        root.option.timestep = self.timestep
        super().build_scene(root)
        self.add_hidden_contacts(root)

    def reset(self, *, seed: int | None = None, options: Mapping[str, Any] | None = None):
        options = check_reset_options(options, self.reset_options)
        old = options.get("context")
        if isinstance(old, Mapping) and ({"physics_key", "physics_space"} & set(old)):
            raise ValueError(f"{self.task_name}: options['context'] holds 'physics_key'/'physics_space', the "
                             "context format before the physics was sealed (the key let anyone compute the hidden "
                             "values); contexts now hold 'goal' and 'physics_token': pass back info['context']")
        physics = options.pop("physics", None)
        self._override = hp.check_values(self.base_task, physics) if physics is not None else None
        if seed is not None:
            self._seed_space = hp.space_of_seed(seed)
        return super().reset(seed=seed, options=options)

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
            lo, hi = lo * (1 + REACH_MARGIN), hi * (1 - REACH_MARGIN)
            glo, ghi = self.goal_distance_range
            if min(hi, ghi) - max(lo, glo) < MIN_GOAL_BAND:
                continue                                 # the physics cannot reach the goal region: redraw it
            while True:
                goal = self.sample_goal(rng)
                if lo <= np.linalg.norm(goal - self.reach_origin) <= hi:
                    return {"goal": goal,
                            "physics_token": hp.seal_token(self.base_task, key, space, self._physics_secret)}
        raise RuntimeError(f"{self.task_name}: no reachable goal for 1000 physics draws")

    def reset_scene(self, context) -> None:
        if self._override is not None:
            values = dict(self._override)
        else:
            if "physics_token" not in context:
                raise ValueError(f"{self.task_name}: options['context'] needs its 'physics_token' (pass back the "
                                 f"context of info['context'] unchanged)")
            key, space = hp.open_token(self.base_task, context["physics_token"], self._physics_secret)
            values = hp.values_of_key(self.base_task, key, space)
        self.set_hidden(values)
        self._hidden = values
        super().reset_scene(context)

    # --- declared by each varied task ------------------------------------------------------------------------------
    goal_distance_range: tuple[float, float] = (0.0, math.inf)

    def add_hidden_contacts(self, root) -> None:
        raise NotImplementedError(f"{type(self).__name__} (a varied task) must implement add_hidden_contacts")

    def set_hidden(self, values: Mapping[str, float]) -> None:
        raise NotImplementedError(f"{type(self).__name__} (a varied task) must implement set_hidden")

    def reach_band(self, values: Mapping[str, float]) -> tuple[float, float]:
        """(nearest, farthest) distance from ``reach_origin`` that the object can end at under ``values``."""
        raise NotImplementedError(f"{type(self).__name__} (a varied task) must implement reach_band")

    def sample_goal(self, rng: np.random.Generator) -> np.ndarray:
        raise NotImplementedError(f"{type(self).__name__} (a varied task) must implement sample_goal")


class PendulumVariedMixin(VariedPhysicsMixin):
    """Hidden bob mass and bob-object restitution; the attempt starts at the bob's first touch of the object."""

    bob_dz = 0.0                    # the sphere collider hits the object at its centre height
    object_geom = ""

    @property
    def rest_half(self) -> float:
        """The object's half-size that the rig's rest pose clears (between attempts, while the object settles)."""
        return self.object_half

    def add_hidden_contacts(self, root) -> None:
        hp.separate_bob(root)
        hp.add_impact_pair(root, hp.BOB_COLLIDER, self.object_geom, "bob_object", hp.BOB_RESTITUTION.nominal,
                           hp.BOB_STIFFNESS)

    def set_hidden(self, values) -> None:
        # mj_setConst (in set_bob_mass) reads the model's current rig pose: put it in the fixed rest pose first, so
        # the derived constants do not depend on the previous attempt's aim (replay stays bit-identical)
        self.pendulum.aim(self.object_start, self.rest_phi, 0.0, self.rest_half, self.bob_dz)
        hp.set_bob_mass(self.model, self.data, values["bob_mass"])
        hp.set_restitution(self.model, "bob_object", values["restitution"], hp.BOB_STIFFNESS)

    def launch_speed(self, values, theta: float) -> float:
        """Closed-form speed of the object after the hit at release angle ``theta`` (for the reach band)."""
        mgd, inertia = hp.pendulum_constants(self.model, bob_mass=values["bob_mass"])
        l = assets.PENDULUM_LENGTH
        v_bob = math.sqrt(2 * mgd * (1 - math.cos(theta)) / inertia) * l
        m_eff = inertia / l ** 2
        m2 = assets.PUCK_MASS if self.object_name == "puck" else assets.BALL_MASS
        return (1 + values["restitution"]) * m_eff / (m_eff + m2) * v_bob

    def _settled(self) -> np.ndarray:
        """The object's pose after settling on its support for SETTLE_TIME (computed once, on a scratch state)."""
        if getattr(self, "_settled_qpos", None) is None:
            import mujoco

            d = mujoco.MjData(self.model)
            a = self._obj_qpos
            d.qpos[a:a + 3] = self.object_start
            d.qpos[a + 3:a + 7] = (1, 0, 0, 0)
            mujoco.mj_step(self.model, d, nstep=int(round(SETTLE_TIME / self.timestep)))
            self._settled_qpos = d.qpos[a:a + 7].copy()
        return self._settled_qpos

    def apply_action(self, action) -> None:
        super().apply_action(action)
        self._start_at_touch(float(action[0]), float(action[1]))

    def _execute(self, action) -> None:
        super()._execute(action)
        if self._robot is not None and self._robot_report.ok:
            self._robot_handover(float(action[0]))

    def _robot_handover(self, phi: float) -> None:
        """Robot mode: the arm has let go of the bob; its free swing to the first touch is integrated in closed form
        from the state the arm left it in (angle and speed, energy conservation), as in the kinematic mode, and the
        object, which the arm never touches, starts from its settled rest pose."""
        import mujoco

        hv = self._hinge_dof()
        theta, omega = float(self.data.qpos[self.pendulum.hinge]), float(self.data.qvel[hv])
        self._start_at_touch(phi, theta, omega)
        mujoco.mj_forward(self.model, self.data)

    def _start_at_touch(self, phi: float, theta: float, omega: float = 0.0) -> None:
        """Object at its settled pose; bob exactly touching it at the speed of a free swing released at ``theta``
        (hinge angle) with hinge speed ``omega`` (0: from rest, the kinematic mode)."""
        obj = self._settled()
        self.data.qpos[self._obj_qpos:self._obj_qpos + 7] = obj
        self.data.qvel[self._obj_qvel:self._obj_qvel + 6] = 0
        pivot = self.pendulum.pivot()
        u = np.array([math.cos(phi), math.sin(phi), 0.0])
        l = assets.PENDULUM_LENGTH
        reach = assets.BOB_HALF + self.object_half - TOUCH_OVERLAP
        horizontal = self.object_name == "puck"

        def gap(th: float) -> float:
            c = pivot + l * (-math.sin(th) * u + np.array([0.0, 0.0, -math.cos(th)]))
            r = c - obj[:3]
            return float(np.hypot(r[0], r[1]) if horizontal else np.linalg.norm(r)) - reach

        lo, hi = -0.2, 0.0                      # the bob touches just past the bottom: gap(lo) < 0 < gap(hi)
        for _ in range(80):
            mid = 0.5 * (lo + hi)
            lo, hi = (mid, hi) if gap(mid) < 0 else (lo, mid)
        touch = 0.5 * (lo + hi)
        self.data.qpos[self.pendulum.hinge] = touch
        if omega == 0.0:
            self.data.qvel[self._hinge_dof()] = -hp.swing_speed(self.model, theta, touch)
        else:
            mgd, inertia = hp.pendulum_constants(self.model)
            w2 = omega * omega + 2.0 * mgd * (math.cos(touch) - math.cos(theta)) / inertia
            self.data.qvel[self._hinge_dof()] = -math.sqrt(max(0.0, w2))

    def _hinge_dof(self) -> int:
        if getattr(self, "_hinge_dof_adr", None) is None:
            import mujoco

            j = mujoco.mj_name2id(self.model, mujoco.mjtObj.mjOBJ_JOINT, "pendulum_hinge")
            self._hinge_dof_adr = int(self.model.jnt_dofadr[j])
        return self._hinge_dof_adr


class PuckVariedMixin(PendulumVariedMixin):
    """The puck tasks: hidden table (and plank) friction too; the puck starts on the frictionless launch pad.

    ``block = True`` (the v1 ids): the puck is a square block (:func:`phyplan_envs.make_block`) on a
    square pad, both turned to the swing plane ``phi`` before each attempt (in robot mode too: the scene turns
    them, not the arm), and the friction pairs use the slow friction reference (``soft_reference``); the closed
    forms below are unchanged (the block leaves the pad ``PAD_RADIUS`` along its path, as the disc does). v0
    (``block = False``): the disc on the round pad.
    """

    object_geom = "puck_geom"
    friction_geoms: tuple[tuple[str, str], ...] = (("table_top", "object_table"),)
    block: bool = False
    turned_bodies: tuple[str, ...] = (hp.PAD_BODY,)   # v1: the static bodies turned to the swing plane

    def add_hidden_contacts(self, root) -> None:
        if self.block:
            make_block(root, self.object_geom)
        super().add_hidden_contacts(root)
        hp.add_launch_pad(root, self.object_start[:2], assets.TABLE_HEIGHT, square=self.block)
        for geom, pair in self.friction_geoms:
            add_friction_pair(root, "puck_geom", geom, pair, hp.FRICTION.nominal, soft_reference=self.block)

    def set_hidden(self, values) -> None:
        super().set_hidden(values)
        for _, pair in self.friction_geoms:
            hp.set_friction(self.model, pair, values["friction"])

    @property
    def rest_half(self) -> float:
        # v1: the block's corner (at yaw 0, while it settles) reaches sqrt(2) times its half edge
        return self.object_half * math.sqrt(2) if self.block else self.object_half

    # --- v1: the block and its supports face the swing plane -------------------------------------------------------
    def face_swing_plane(self, phi: float) -> None:
        """Turn the pad (and the task's other :attr:`turned_bodies`) to the swing plane ``phi`` (v1)."""
        for name in self.turned_bodies:
            turn_body(self.model, self.body_id(name), phi)

    def reset_scene(self, context) -> None:
        if self.block:
            self.face_swing_plane(0.0)             # neutral between attempts: a reset does not depend on history
        super().reset_scene(context)
        if self.block:                             # the resting rig clears the (unturned) block's corners
            self.pendulum.aim(self.object_start, self.rest_phi, 0.0, self.rest_half, self.bob_dz)

    def _settled(self) -> np.ndarray:
        if self.block and getattr(self, "_settled_qpos", None) is None:
            # settle at a fixed yaw with the rig at its rest pose clear of the block's corners (the caller has aimed
            # it at this attempt's swing plane): the pose depends on neither the first aim nor the history
            m = self.model
            rig = self.pendulum.rig
            pose = (m.body_pos[rig].copy(), m.body_quat[rig].copy(), self.data.qpos[self.pendulum.hinge])
            self.face_swing_plane(0.0)
            self.pendulum.aim(self.object_start, self.rest_phi, 0.0, self.rest_half, self.bob_dz)
            settled = super()._settled()
            m.body_pos[rig], m.body_quat[rig] = pose[0], pose[1]
            self.data.qpos[self.pendulum.hinge] = pose[2]
            return settled
        return super()._settled()

    def _start_at_touch(self, phi: float, theta: float, omega: float = 0.0) -> None:
        super()._start_at_touch(phi, theta, omega)
        if self.block:
            self.face_swing_plane(phi)
            turn_free_body(self.data.qpos, self._obj_qpos, phi)

    def _execute(self, action) -> None:
        if self.block and self._robot is not None:   # robot mode: the scene turns block and pad before the arm moves
            phi = float(action[0])
            self.face_swing_plane(phi)
            turn_free_body(self.data.qpos, self._obj_qpos, phi)
        super()._execute(action)

    def sample_goal(self, rng):
        return self.reach_origin + polar(rng.uniform(*self.goal_distance_range), rng.uniform(0.0, math.pi / 2))

    def stop_distance(self, values, theta: float) -> float:
        """Closed form: frictionless across the pad, then v^2 / (2 mu g)."""
        v = self.launch_speed(values, theta)
        return hp.PAD_RADIUS + v * v / (2 * values["friction"] * assets.GRAVITY)


