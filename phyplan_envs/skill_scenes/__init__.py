"""Skill-data scenes: seeded MuJoCo rollouts that record what each of the five PhyPlan skills predicts.

The skill models of :mod:`phyplan_agents.skills` learn from the data made here. Every scene is built from the same
pieces and constants as the tasks (:mod:`phyplan_envs.assets`: ``arena`` with its timestep, gravity and elliptic
friction cones, ``add_pendulum``, ``add_ball``, ``add_puck``, ``add_table``, ``add_pedestal``; the task files'
facts: start positions, landing heights, table friction), so that a skill learnt here predicts what happens inside
a task. One module per skill (:mod:`.swing`, :mod:`.slide`, :mod:`.throw`, :mod:`.hit`, :mod:`.bounce`), each with
its scene, its sampled domain and its :data:`DataSpec <DATA_SPECS>`; :mod:`.common` holds what they share.

===========  =====================================  ===========================================================
skill        inputs -> outputs                      recorded from
===========  =====================================  ===========================================================
``swing``    (theta_init, t) -> (theta, omega)      the task pendulum released from rest at ``theta_init``
``slide``    (v_init, t) -> (x, v)                  the task puck launched along +x on the task table (mu 0.2)
``throw``    (v_hor, v_ver, t) -> (x, y, v_ver)     the task ball in free flight
``hit``      (m1, m2, v_init) -> (v,)               the task pendulum hitting the ball on the pedestal or the puck
                                                    on the table, with the bob mass and object mass varied
``hit_free`` (m1, m2, v_init, edge)                 the same hit of the ball, its free flight taken 0.115 m out
             -> (dz, v_hor, v_ver)                  along the swing: height and velocity there (:mod:`.hit_free`)
``bounce``   (e, wedge_angle, v_ver, v_hor)         the task ball hitting a frictionless elastic incline
             -> (v_ver, v_hor)
===========  =====================================  ===========================================================

The Paddles task's skills (new names; the skills above are unchanged): ``swing_wide``, ``hit_wide``, ``throw_wide``
(:mod:`.wide`: the same scenes over wider domains), ``glide`` (:mod:`.glide`: the ball gliding on a frictionless
incline board, ``(incline_angle, v_down0, v_across0, t) -> (s_down, s_across, v_down)``) and ``bounce_general_low``,
``bounce_general_low_cond`` (:mod:`.bounce_general_low`: the general bounce at restitution 0.02-0.45, 0.5 ms).
For balls falling through bouncing paddles: ``bounce_general_fast`` (:mod:`.bounce_general` at up to 10 m/s) and
``throw_fast`` (:mod:`.wide`: up to 6 m/s upwards and 1.6 s). For PaddlesVaried-v3's exact impacts:
``bounce_general_exact_cond`` (:mod:`.bounce_exact`).

Units: radians, metres, seconds, kilograms. Sign conventions (shared with the PhyPlan agent):

* all vertical quantities are up-positive; throw's ``y`` is the vertical displacement from the release point;
* swing's ``theta`` is the hinge angle from vertical (positive on the release side), ``omega = d theta / dt``
  (negative while the bob swings down towards the object); the bob's speed is ``|omega| * PENDULUM_LENGTH``;
* slide's ``x`` is the distance slid along the launch direction, ``v`` the velocity along it;
* bounce's ``v_hor`` and output ``v_hor`` are along the incline's downslope horizontal direction; the incoming
  ``v_ver`` is negative (falling).

Measured definitions that matter for chaining skills (see ``docs/skills.md``):

* **hit** outputs the *outcome-equivalent launch speed* (:mod:`.hit`): the object's separation speed from the soft
  bob contact does not predict where it goes (the Launch ball lands as if launched 6-9 % faster, the Slide puck
  stops as if launched up to ~10 % faster), so the recorded ``v`` is the speed an instantaneous hit would need to
  give the same outcome; ``v_init`` is the bob's speed measured at the first bob-object contact.
* **slide** records only the sliding phase (speed above ``SLIDE_END_SPEED``): the model continues the motion with
  constant deceleration beyond the stop, and a caller reads the stopping distance where ``v`` crosses 0.
* **bounce** records the ball's velocity just before the first contact with the incline and just after the contact
  ends (it lasts 5-15 ms); ``e`` is the nominal restitution of the incline's ``solref``
  (:func:`phyplan_envs.contact.solref_for_restitution`).

Layering: this package is simulation, so it lives in the envs and imports nothing from the agents. What it records
(column names, units, the sampled domain) is declared here as a :class:`DataSpec` per skill; the model-facing
contract (which input is the query time, the skills' names and aliases) is
:class:`phyplan_agents.skills.contract.SkillSpec`, which is built on these ``DataSpec`` s.
"""
from __future__ import annotations

from typing import Callable

import numpy as np

from ..contact import restitution_of_solref, solref_for_restitution
from . import (bounce, bounce_cond, bounce_exact, bounce_general, bounce_general_low, glide, hit, hit_cond, hit_free,
               slide, slide_cond, swing, throw, wide)
from .bounce import (BOUNCE_ANGLE, BOUNCE_E, BOUNCE_MIN_APPROACH, BOUNCE_STIFFNESS, BOUNCE_V_HOR, BOUNCE_V_VER,
                     INCLINE_HALF, INCLINE_POINT, bounce_one, bounce_scene)
from .common import DATA_SPECS, DataSpec, Scene, SkillData
from .hit import HIT_M1, HIT_M2_BALL, HIT_M2_PUCK, HIT_PHI, HIT_V, HitScene
from .slide import SLIDE_END_SPEED, SLIDE_T, SLIDE_V, measured_slide_mu, slide_rollout, slide_scene
from .swing import SWING_T, SWING_THETA, pendulum_equivalent_length, swing_scene
from .throw import THROW_START_Z, THROW_T, THROW_V_HOR, THROW_V_VER, throw_scene

_MODULES = {"swing": swing, "slide": slide, "throw": throw, "hit": hit, "bounce": bounce}
# the hidden-physics track's parameter-conditioned skills (data over the training space of
# phyplan_envs.hidden_physics; see each module)
_MODULES.update({"slide_cond": slide_cond, "hit_cond": hit_cond, "bounce_cond": bounce_cond})
# the general-incidence bounce (one module, two physics: the Bounce-v0 wedge contact; the varied track's impact pair)
_MODULES.update({"bounce_general": bounce_general, "bounce_general_cond": bounce_general.COND})

# the Paddles task's skills: wide-range swing/hit/throw (.wide), the glide on a frictionless incline (.glide) and the
# low-restitution general bounce at 0.5 ms under both physics (.bounce_general_low)
_MODULES.update({"swing_wide": wide.SWING_WIDE, "hit_wide": wide.HIT_WIDE, "throw_wide": wide.THROW_WIDE,
                 "glide": glide, "bounce_general_low": bounce_general_low.LOW,
                 "bounce_general_low_cond": bounce_general_low.LOW_COND})

# the ball's physical state when the hit sets it free (the hand-over to a flight that meets a face: .hit_free)
_MODULES.update({"hit_free": hit_free, "hit_free_cond": hit_free.COND, "hit_free_slow": hit_free.SLOW})
# the bounce off steep faces up to vertical walls (.bounce_general, 80-90 degrees)
_MODULES.update({"bounce_wall": bounce_general.WALL, "bounce_wall_cond": bounce_general.WALL_COND})
# the general bounce at up to 10 m/s (.bounce_general: balls falling through bouncing paddles)
_MODULES["bounce_general_fast"] = bounce_general.FAST
# the free flight of a ball bouncing off paddles (.wide: faster, upwards, longer)
_MODULES["throw_fast"] = wide.THROW_FAST
# the general bounce off faces with exact impacts (.bounce_exact: PaddlesVaried-v3's paddles)
_MODULES["bounce_general_exact_cond"] = bounce_exact.EXACT_COND

DATA_SPECS.update({name: mod.DATA for name, mod in _MODULES.items()})
# DATA_SPECS: skill name -> what its scene records (columns, units, sampled domain), in the order swing, slide, throw,
# hit, bounce, the conditioned and the general bounce's (the dict of .common, which SkillData.spec reads)

_GENERATORS: dict[str, Callable] = {name: mod.generate_samples for name, mod in _MODULES.items()}

# distinct random streams per skill for the same seed
_SKILL_SALT = {"swing": 11, "slide": 12, "throw": 13, "hit": 14, "bounce": 15,
               "slide_cond": 16, "hit_cond": 17, "bounce_cond": 18, "bounce_general": 19, "bounce_general_cond": 20,
               "swing_wide": 21, "hit_wide": 22, "throw_wide": 23, "glide": 24, "bounce_general_low": 25,
               "bounce_general_low_cond": 26, "hit_free": 27,
               "hit_free_cond": 28, "bounce_wall": 29, "bounce_wall_cond": 30, "bounce_general_fast": 31,
               "throw_fast": 32, "bounce_general_exact_cond": 33, "hit_free_slow": 34}


def generate(skill: str, n: int, seed: int, progress: bool = False) -> SkillData:
    """``n`` samples of ``skill`` from seeded MuJoCo rollouts (deterministic in ``seed``).

    Each sample is one rollout with initial conditions drawn uniformly from the skill's ranges (see
    :data:`DATA_SPECS`) and, for the time-parameterised skills, one query time drawn uniformly (on the 1 ms timestep
    grid) from the time range (slide: from its sliding phase). Row i depends only on (seed, i), so a smaller set is a
    prefix of a larger one with the same seed.

    Costs on one idle core (measured): swing, throw and bounce ~1 ms a sample, slide ~9 ms, hit ~20 ms.
    """
    name = str(skill).lower()
    if name not in DATA_SPECS:
        raise ValueError(f"unknown skill {skill!r}; skills: {', '.join(DATA_SPECS)}")
    if int(n) != n or n < 1:
        raise ValueError(f"n must be a positive integer, got {n!r}")
    rng = np.random.default_rng([int(seed), _SKILL_SALT[name]])
    x, y, extras = _GENERATORS[name](int(n), rng, progress)
    if not (np.all(np.isfinite(x)) and np.all(np.isfinite(y))):
        raise RuntimeError(f"{name} data has non-finite values (seed {seed})")
    return SkillData(name, x, y, int(seed), extras)


__all__ = [
    "BOUNCE_ANGLE", "BOUNCE_E", "BOUNCE_MIN_APPROACH", "BOUNCE_STIFFNESS", "BOUNCE_V_HOR", "BOUNCE_V_VER",
    "DATA_SPECS", "DataSpec", "HIT_M1", "HIT_M2_BALL", "HIT_M2_PUCK", "HIT_PHI", "HIT_V", "HitScene",
    "INCLINE_HALF", "INCLINE_POINT", "SLIDE_END_SPEED", "SLIDE_T", "SLIDE_V", "SWING_T", "SWING_THETA", "Scene",
    "SkillData", "THROW_START_Z", "THROW_T", "THROW_V_HOR", "THROW_V_VER", "bounce_one", "bounce_scene", "generate",
    "measured_slide_mu", "pendulum_equivalent_length", "restitution_of_solref", "slide_rollout", "slide_scene",
    "solref_for_restitution", "swing_scene", "throw_scene",
]
