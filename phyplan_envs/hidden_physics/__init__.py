"""Hidden physics of the varied tasks, in one package: the parameters, their train/test spaces, the contacts that obey
them and the env component that draws and sets them per context.

* :mod:`.declaration`: the declaration (:data:`PARAMETERS`: each base task's parameters with their nominal values and
  spaces), physics keys and the sealed context token, and the task names (:func:`base_task`, :func:`is_varied`,
  :func:`varied_tasks`, :func:`parameter_names`: what agents read; nothing else declares the table);
* :mod:`.contacts`: the MuJoCo side (calibrated impact pairs, friction pairs, the bob's own body, the pendulum's
  closed-form swing, the launch pad); :mod:`.impacts`: exact impacts resolved inside the timestep (PaddlesVaried-v3's
  paddles, whose physics step the flight takes from the component: ``env.hidden.stepper()``);
* :mod:`.component`: the component an env holds (``env.hidden``): :class:`NoHiddenPhysics` (the nominal tasks),
  :class:`HiddenPhysics`, and :func:`varied` (a varied task class: the nominal one plus a component);
  :mod:`.pendulum` (:class:`PendulumHidden`, :class:`PuckHidden`) and :mod:`.tasks` (each varied task's reach band
  and goals, Bounce's restitution).

A varied task (``PhyPlan/<Task>Varied-vN``) draws, per context, physical parameters that the agent never sees:

==============  =====================  ==========  ================  ===============================  ============
parameter       tasks                  nominal     train space       test space                       sampling
==============  =====================  ==========  ================  ===============================  ============
``bob_mass``    slide, bridge          0.5 kg      [0.3, 1.0]        [0.1, 0.3) U (1.0, 6.0]          log-uniform
``bob_mass``    launch                 0.5 kg      [0.3, 1.0]        [0.05, 0.3) U (1.0, 3.0]         log-uniform
``restitution`` launch, slide, bridge  0.5         [0.35, 0.65]      [0.05, 0.35) U (0.65, 0.95]      uniform
``friction``    slide, bridge          0.35        [0.25, 0.45]      [0.15, 0.25) U (0.45, 0.6]       uniform
``restitution`` bounce                 0.8         [0.7, 0.9]        [0.4, 0.7) U (0.9, 0.99]         uniform
==============  =====================  ==========  ================  ===============================  ============

``bob_mass`` is the pendulum bob's mass; ``restitution`` that of the bob-object contact (pendulum tasks) or of the
ball-incline contact (Bounce); ``friction`` the sliding friction of the puck on the table top and the bridge plank.
The two spaces are disjoint and the test space is wider (CausalWorld's spaces A and B): contexts of the ``test``
split (:mod:`phyplan_envs.splits`) draw from the test space, ``train`` and ``dev`` contexts from the train space.

How the contacts obey the parameters (``docs``: the varied tasks' docstrings; measured by
``python -m benchmarks.design_checks.hidden_physics``):

* restitution: a ``<pair>`` with MuJoCo's negative ``solref`` (-K, -D) and a constant impedance
  (``solimp = (IMPEDANCE, IMPEDANCE, ...)``), so the contact is a linear spring-damper whose bounce does not depend
  on the impact speed or the masses. D is *calibrated*: the damping for which two spheres started exactly touching
  separate with relative speed ratio e at the task's timestep (:func:`calibrated_damping`). The closed form of
  :mod:`phyplan_envs.contact` ignores that a contact never pulls and the time discretisation (set 0.2 gave 0.29).
* friction: a ``<pair>`` with ``friction = (mu, mu, 0.005, 1e-4, 1e-4)`` (condim 3).
* bob mass: the bob is its own body (a welded child of the pendulum arm) whose mass and (isotropic) inertia are set
  in the compiled model (:func:`set_bob_mass`).

A context's values are a function of an integer key and the space's name (:func:`values_of_key`). The context
holds neither: its ``physics_token`` is the pair sealed under the process's secret (:func:`seal_token`,
:data:`phyplan_envs.spaces.SECRET_ENV`), which an env holding the same secret opens (:func:`open_token`), so
``reset(options={"context": ...})`` replays a context exactly while the context, the observation and ``info`` hold
no value and no key. No public function returns the secret; the threat model is in docs/hidden-physics.md.
"""
from __future__ import annotations

from .component import (MIN_GOAL_BAND, ON_PAD, REACH_MARGIN, SETTLE_TIME, TIMESTEP, TOUCH_OVERLAP, HiddenPhysics,
                        NoHiddenPhysics, varied)
from .contacts import (BOB_BODY, BOB_COLLIDER, BOB_STIFFNESS, IMPEDANCE, INCLINE_STIFFNESS, PAD_BODY, PAD_RADIUS,
                       PAD_RISE, PAD_THICK, add_impact_pair, add_launch_pad, calibrated_damping, impact_solref,
                       measured_restitution, pendulum_constants, separate_bob, set_bob_mass, set_friction,
                       set_restitution, swing_speed)
from .declaration import (BOB_MASS, BOB_RESTITUTION, FRICTION, INCLINE_RESTITUTION, KEY_BOUND, LAUNCH_BOB_MASS,
                          PADDLE_RESTITUTION,
                         PARAMETERS, SPACES, TOKEN_ENTRY, VARIED_SUFFIX, HiddenParameter, base_task, check_key,
                         check_space, check_values, draw, is_varied, nominal, open_token, parameter_names, parameters,
                         seal_token, space_of_seed, values_of_key, varied_name, varied_tasks)
from .pendulum import PendulumHidden, PuckHidden
from .impacts import GLIDE_SPEED, FaceImpacts
from .tasks import (BounceHidden, BridgeHidden, LaunchBounceHidden, LaunchHidden, PaddlesHidden, PaddlesImpactHidden,
                    SlideHidden)

__all__ = ["BOB_BODY", "BOB_COLLIDER", "BOB_MASS", "BOB_RESTITUTION", "BOB_STIFFNESS", "BounceHidden", "BridgeHidden",
           "FaceImpacts", "GLIDE_SPEED", "PaddlesImpactHidden",
           "FRICTION", "HiddenParameter", "HiddenPhysics", "IMPEDANCE", "INCLINE_RESTITUTION", "INCLINE_STIFFNESS",
           "KEY_BOUND", "LAUNCH_BOB_MASS", "LaunchBounceHidden", "LaunchHidden", "PaddlesHidden", "MIN_GOAL_BAND", "NoHiddenPhysics", "ON_PAD", "PAD_BODY",
           "PADDLE_RESTITUTION", "PAD_RADIUS", "PAD_RISE", "PAD_THICK", "PARAMETERS", "PendulumHidden", "PuckHidden", "REACH_MARGIN",
           "SETTLE_TIME", "SPACES", "SlideHidden", "TIMESTEP", "TOKEN_ENTRY", "TOUCH_OVERLAP", "VARIED_SUFFIX",
           "add_impact_pair", "add_launch_pad", "base_task", "calibrated_damping", "check_key", "check_space",
           "check_values", "draw", "impact_solref", "is_varied", "measured_restitution", "nominal", "open_token",
           "parameter_names", "parameters", "pendulum_constants", "seal_token", "separate_bob", "set_bob_mass",
           "set_friction", "set_restitution", "space_of_seed", "swing_speed", "values_of_key", "varied",
           "varied_name", "varied_tasks"]
