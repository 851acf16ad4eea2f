"""Skill chains: what the PhyPlan agent believes about each task, i.e. how its skills compose into the outcome.

A *skill chain* is one module per task (``chains/<task>.py``) with two names:

* ``SKILLS``: the skills in the order the chain applies them (e.g. Launch: swing -> hit -> throw);
* ``rollout(state, actions, skills, facts)``: the chain run on a batch of actions, returning the predicted final
  xy ``(N, 2)`` of the moving object. It reads only the state vector (a float32 tensor), the skill models and the
  task's declared physical facts (``phyplan_envs.task_class(task).facts``: masses, heights, restitution, ...).

:data:`CHAINS` maps a task name to its :class:`Chain`; :func:`chain_for` looks one up with a clear error.
:class:`phyplan_agents.phyplan.predictor.ChainPredictor` turns a chain, skill models and a context into the
predicted reward the planner maximises. A new task gets a chain by adding its module here and a line in
:data:`CHAINS`; the envs know nothing about chains.
"""
from __future__ import annotations

from typing import Callable, NamedTuple

from . import bounce, bridge, launch, slide, varied


class Chain(NamedTuple):
    """One task's skill chain: its name, the skills in order, and ``rollout(state, actions, skills, facts)``."""

    task: str
    skills: tuple[str, ...]
    rollout: Callable


CHAINS: dict[str, Chain] = {
    "launch": Chain("launch", launch.SKILLS, launch.rollout),
    "slide": Chain("slide", slide.SKILLS, slide.rollout),
    "bounce": Chain("bounce", bounce.SKILLS, bounce.rollout),
    "bridge": Chain("bridge", bridge.SKILLS, bridge.rollout),
    # the hidden-physics track: each action row is followed by the physics (hidden_physics.parameter_names(task))
    "launch-varied": Chain("launch-varied", varied.LAUNCH_SKILLS, varied.launch),
    "slide-varied": Chain("slide-varied", varied.SLIDE_SKILLS, varied.slide),
    "bounce-varied": Chain("bounce-varied", varied.BOUNCE_SKILLS, varied.bounce),
    "bridge-varied": Chain("bridge-varied", varied.BRIDGE_SKILLS, varied.bridge),
}


def chain_for(task: str) -> Chain:
    """The skill chain of task ``task`` (``"launch"``, ``"slide"``, ...); ``ValueError`` naming the known tasks."""
    try:
        return CHAINS[task]
    except (KeyError, TypeError):
        raise ValueError(f"task {task!r} has no skill chain; tasks with one: {', '.join(CHAINS)} (add a module "
                         f"to phyplan_agents/phyplan/chains/ and a line in CHAINS)") from None


__all__ = ["CHAINS", "Chain", "chain_for"]
