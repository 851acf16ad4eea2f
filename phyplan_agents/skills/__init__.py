"""Skill models: the paper's physics-informed (PINN) and data-only (NN) skill networks, trained on MuJoCo data.

>>> from phyplan_agents.skills import load_skill, SkillSet
>>> swing = load_skill("swing")                       # the shipped PINN
>>> swing.predict(torch.tensor([[1.0, 0.2]]))         # (theta_init, t) -> (theta, omega)
>>> skills = SkillSet.load()                          # .swing .slide .throw .hit .bounce

=========  ===========================================  =================
skill      inputs -> outputs (physical units)           default kind
=========  ===========================================  =================
swing      (theta_init, t) -> (theta, omega)            pinn
slide      (v_init, t) -> (x, v)                        pinn (learns mu)
throw      (v_hor, v_ver, t) -> (x, y, v_ver)           pinn
hit        (m1, m2, v_init) -> (v,)                     nn (data only)
bounce     (e, wedge_angle, v_ver, v_hor) -> (v_ver,    nn (data only)
           v_hor)
=========  ===========================================  =================

The Paddles task's skills (``SkillSet`` attributes too): ``swing_wide``, ``hit_wide``, ``throw_wide`` (the same
scenes over wider domains), ``glide`` ((incline_angle, v_down0, v_across0, t) -> (s_down, s_across, v_down) on a
frictionless board; pinn) and ``bounce_general_low`` / ``bounce_general_low_cond`` (the general bounce at low
restitution, 0.5 ms; pinn); ``python -m phyplan_agents.skills.train --paddles`` rebuilds them. For balls falling
through bouncing paddles (``SkillSet`` attributes too): ``bounce_general_fast`` (the general bounce at up to 10 m/s)
and ``throw_fast`` (the free flight at up to 6 m/s upwards and 1.6 s); ``--bouncing-paddles`` rebuilds them.

The skill contract (what each skill maps from and to, its time input, its names) is :mod:`.contract`; the data
come from :mod:`phyplan_envs.skill_scenes` (the scenes, sign conventions, the sampled domains); training from
:mod:`.training`; the command line is ``python -m phyplan_agents.skills.train``. See ``docs/skills.md``.
"""
from .contract import ALIASES, SKILLS, SkillSpec, skill_spec
from .io import SkillFileError, SkillSet, load_skill, save
from .models import DEFAULT_KIND, KINDS, PINN_SKILLS, SkillModel

__all__ = ["ALIASES", "DEFAULT_KIND", "KINDS", "PINN_SKILLS", "SKILLS", "SkillFileError", "SkillModel", "SkillSet",
           "SkillSpec", "load_skill", "save", "skill_spec"]
