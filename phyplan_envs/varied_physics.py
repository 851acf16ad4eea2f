"""The hidden-physics component of an env, held as ``env.hidden`` (its class: the env's class attribute
``hidden_model``): :class:`NoHiddenPhysics` for the nominal tasks, and for the varied tasks
(:mod:`phyplan_envs.tasks.varied`: each its nominal assembly plus one of these) a :class:`HiddenPhysics`.

:class:`HiddenPhysics` draws per-context values from the train or test space (:mod:`phyplan_envs.hidden_physics`)
behind a sealed ``physics_token``, redraws goals until reachable, and serves the privileged ``hidden_physics``
accessor and the ``physics`` reset option. :class:`PendulumHidden` (bob mass and bob-object restitution, the attempt
starting at the bob's first touch) and :class:`PuckHidden` (plus table and plank friction, the puck on its launch
pad) are the parts the pendulum tasks share; each task's own (reach band, goal range; Bounce's ball-incline
restitution) is in :mod:`phyplan_envs.tasks.varied`.

The env calls the component from one place each (:class:`NoHiddenPhysics` does the nominal thing): ``adapt(tools)``
(it takes over parts of the assembly) and ``build(root)`` (its contacts) while building; ``take_options``,
``sample_context``, ``check_context_entry`` and ``reset_scene(context, reset_tools)`` at a reset;
``after_apply(action)`` at the end of the kinematic set-up, and in robot mode ``before_arm(action)`` and
``after_arm(action)`` around the arm's set-up.
"""
from __future__ import annotations

import dataclasses
import math
from typing import Any, Mapping

import mujoco
import numpy as np

from . import assets
from . import hidden_physics as hp
from .block import add_friction_pair
from .spaces import _process_secret, short_repr
from .tools.supports import polar_goal

TIMESTEP = 0.0005          # s (the nominal tasks: 0.001)
REACH_MARGIN = 0.03        # the reach band is shrunk by this fraction at each end before goals are drawn
MIN_GOAL_BAND = 0.03       # m: narrower overlaps of reach band and goal region redraw the physics
TOUCH_OVERLAP = 1e-9       # m: the bodies start this far inside each other, so the contact is active at step 1
SETTLE_TIME = 0.3          # s: the object settles on its support before the first touch (as during a swing)
ON_PAD = np.array([0.0, 0.0, hp.PAD_RISE])     # the puck's start on its launch pad, above the nominal start


def varied(name: str, module: str, nominal: type, hidden: type, doc: str, **attrs: Any) -> type:
    """The varied task class ``name`` (of module ``module``, documented by ``doc``): ``nominal``'s assembly plus the
    hidden-physics component ``hidden``, its timestep :data:`TIMESTEP`; ``hidden.varied_attributes(nominal)`` (the
    nominal facts the hidden physics changes) and ``attrs`` set the rest. A subclass of ``nominal`` that only sets
    class attributes: its methods are the nominal task's."""
    body = {"__module__": module, "__qualname__": name, "__doc__": doc, "task_name": f"{nominal.task_name}-varied",
            "base_task": nominal.task_name, "hidden_model": hidden, "timestep": TIMESTEP,
            "object_geom": f"{nominal.object_name}_geom", **hidden.varied_attributes(nominal), **attrs}
    return type(name, (nominal,), body)


class NoHiddenPhysics:
    """The nominal tasks' physics: nothing hidden (the context is the goal); every call does the nominal thing."""

    context_keys: tuple[str, ...] = ()
    reset_options: tuple[str, ...] = ()
    override = None

    def __init__(self, env, physics_space=None):
        if physics_space is not None:
            raise TypeError(f"{type(env).__name__} has no hidden physics: physics_space is an argument of the "
                            "varied tasks")
        self.env = env

    def values(self) -> dict[str, float]:
        raise AttributeError(f"{type(self.env).__name__} has no hidden physics")

    @property
    def parameters(self) -> tuple:
        raise AttributeError(f"{type(self.env).__name__} has no hidden physics")

    def adapt(self, tools) -> None:
        """Take over parts of the nominal assembly before it is built; default none."""

    def build(self, root) -> None:
        """Add the component's contacts to the scene; default none."""

    def take_options(self, seed: int | None, options: dict[str, Any]) -> None:
        """Pop the component's reset options; default none."""

    def check_context_entry(self, name: str, value: Any) -> Any:
        raise ValueError(f"{self.env.task_name}: options['context'][{name!r}] has no check; a task that adds a "
                         "context entry declares it in context_keys and checks it in check_context_entry")

    def sample_context(self, rng: np.random.Generator) -> dict[str, Any]:
        return {"goal": self.env.sample_goal(rng)}

    def reset_scene(self, context, reset_tools) -> None:
        reset_tools()

    def after_apply(self, action) -> None:
        """The kinematic set-up is done (the tools placed for ``action``); default nothing."""

    def before_arm(self, action) -> None:
        """Robot mode: the scene before the arm moves; default nothing."""

    def after_arm(self, action) -> None:
        """Robot mode: the arm has let go (its set-up succeeded); default nothing."""


class HiddenPhysics(NoHiddenPhysics):
    """Hidden physics of the varied env ``env`` (its ``base_task`` names the parameters).

    Args (of the env, besides the nominal task's):
        physics_space: ``"auto"`` (default: ``reset(seed=s)`` with s in the test split draws from the test space,
            other seeds from the train space; an unseeded reset keeps the last seeded reset's space), ``"train"`` or
            ``"test"``.

    Reset options (besides the nominal ones): ``physics``: a dict of all hidden values to use instead of the
    context's (privileged: data generation and analysis; the harness never passes it).

    The context is ``{"goal", "physics_token"}``: the token seals the context's physics key and space under the
    secret the env took from its process at construction (:data:`phyplan_envs.spaces.SECRET_ENV`), so only an env
    holding that secret replays it (in this process or a child that inherited the variable; any other raises).
    """

    context_keys = ("physics_token",)
    reset_options = ("physics",)
    goal_distance_range: tuple[float, float] = (0.0, math.inf)

    @classmethod
    def varied_attributes(cls, nominal: type) -> dict[str, Any]:
        """The class attributes of the nominal task ``nominal`` that this hidden physics changes; default none."""
        return {}

    def __init__(self, env, physics_space: str | None = None):
        physics_space = "auto" if physics_space is None else physics_space
        if not isinstance(physics_space, str):
            raise TypeError(f"physics_space must be 'auto', 'train' or 'test', got {type(physics_space).__name__} "
                            f"{short_repr(physics_space)}")
        if physics_space != "auto":
            hp.check_space(physics_space)
        super().__init__(env)
        self.base_task = env.base_task
        self.physics_space = env.physics_space = physics_space
        self._seed_space = "train"
        self._hidden: dict[str, float] | None = None
        self.override: dict[str, float] | None = None     # this reset's ``physics`` option
        self._physics_secret = _process_secret()
        env.chunk = max(1, int(round(0.005 / env.timestep)))   # end-rule checks every 5 ms, as the nominal tasks

    # --- privileged --------------------------------------------------------------------------------------------
    def values(self) -> dict[str, float]:
        """The current context's hidden values: the one privileged accessor, for the harness's reports, diagnostics,
        design checks and tests, never for an agent (an agent in this process can read it, as any memory: the
        guarantee is that the context, the observation, ``info`` and the public functions do not give it away;
        docs/hidden-physics.md, *Threat model*)."""
        if self._hidden is None:
            raise RuntimeError("call reset() before reading hidden_physics")
        return dict(self._hidden)

    @property
    def parameters(self) -> tuple[hp.HiddenParameter, ...]:
        return hp.parameters(self.base_task)

    # --- the env's calls ---------------------------------------------------------------------------------------
    def take_options(self, seed: int | None, options: dict[str, Any]) -> None:
        """Pop the ``physics`` option of this reset (validated) and note the space of a seeded reset; a context in
        the format before the physics was sealed is refused."""
        old = options.get("context")
        if isinstance(old, Mapping) and ({"physics_key", "physics_space"} & set(old)):
            raise ValueError(f"{self.env.task_name}: options['context'] holds 'physics_key'/'physics_space', the "
                             "context format before the physics was sealed (the key let anyone compute the hidden "
                             "values); contexts now hold 'goal' and 'physics_token': pass back info['context']")
        physics = options.pop("physics", None)
        self.override = hp.check_values(self.base_task, physics) if physics is not None else None
        if seed is not None:
            self._seed_space = hp.space_of_seed(seed)

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
        raise RuntimeError(f"{self.env.task_name}: no reachable goal for 1000 physics draws")

    def reset_scene(self, context, reset_tools) -> None:
        """The context's hidden values set, then the nominal tools' reset (``reset_tools()``)."""
        if self.override is not None:
            values = dict(self.override)
        else:
            if "physics_token" not in context:
                raise ValueError(f"{self.env.task_name}: options['context'] needs its 'physics_token' (pass back the "
                                 f"context of info['context'] unchanged)")
            key, space = hp.open_token(self.base_task, context["physics_token"], self._physics_secret)
            values = hp.values_of_key(self.base_task, key, space)
        self.set_hidden(values)
        self._hidden = values
        reset_tools()

    # --- declared by each task's component ------------------------------------------------------------------------
    def set_hidden(self, values: Mapping[str, float]) -> None:
        raise NotImplementedError(f"{type(self).__name__} must implement set_hidden")

    def reach_band(self, values: Mapping[str, float]) -> tuple[float, float]:
        """(nearest, farthest) distance from ``reach_origin`` that the object can end at under ``values``."""
        raise NotImplementedError(f"{type(self).__name__} must implement reach_band")

    def sample_goal(self, rng: np.random.Generator) -> np.ndarray:
        raise NotImplementedError(f"{type(self).__name__} must implement sample_goal")


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
        hp.separate_bob(root)
        hp.add_impact_pair(root, hp.BOB_COLLIDER, self.target.geom, "bob_object", hp.BOB_RESTITUTION.nominal,
                           hp.BOB_STIFFNESS)

    def set_hidden(self, values) -> None:
        # mj_setConst (in set_bob_mass) reads the model's current rig pose: put it in the fixed rest pose first, so
        # the derived constants do not depend on the previous attempt's aim (replay stays bit-identical)
        env = self.env
        self.rig.aim_at_target(self.rig.rest_phi, 0.0, self.rest_half)
        hp.set_bob_mass(env.model, env.data, values["bob_mass"])
        hp.set_restitution(env.model, "bob_object", values["restitution"], hp.BOB_STIFFNESS)

    def sample_goal(self, rng):
        return polar_goal(rng, self.reach_origin, self.goal_distance_range)

    def launch_speed(self, values, theta: float) -> float:
        """Closed-form speed of the object after the hit at release angle ``theta`` (for the reach band)."""
        mgd, inertia = hp.pendulum_constants(self.env.model, bob_mass=values["bob_mass"])
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
            data.qvel[rig.hinge_dof] = -hp.swing_speed(env.model, theta, touch)
        else:
            mgd, inertia = hp.pendulum_constants(env.model)
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
            puck.supports = (hp.PAD_BODY,) + puck.supports

    def build(self, root) -> None:
        super().build(root)
        hp.add_launch_pad(root, self.target.start[:2], assets.TABLE_HEIGHT, square=self.block)
        for geom, pair in self.friction_geoms:
            add_friction_pair(root, self.target.geom, geom, pair, hp.FRICTION.nominal, soft_reference=self.block)

    def set_hidden(self, values) -> None:
        super().set_hidden(values)
        for _, pair in self.friction_geoms:
            hp.set_friction(self.env.model, pair, values["friction"])

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

    def stop_distance(self, values, theta: float) -> float:
        """Closed form: frictionless across the pad, then v^2 / (2 mu g)."""
        v = self.launch_speed(values, theta)
        return hp.PAD_RADIUS + v * v / (2 * values["friction"] * assets.GRAVITY)
