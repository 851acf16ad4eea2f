"""Perception: the PhyPlan agent's belief about a scene, read from the RGB-D observation alone.

* :mod:`.vision`: colour classes, connected components, back-projection, silhouette points and shape fits;
* :mod:`.reads`: one RGB-D picture (:class:`~.reads.RGBDView`) and what it shows object by object: the goal box,
  a ball, a puck, a horizontal surface;
* :mod:`.scene`: per task, the state vector the skill chains read (goal, object start, wedge / table / plank),
  as a :class:`Percept` whose ``problems`` say what could not be measured;
* :mod:`.agent`: ``phyplan-perception``, the PhyPlan agent planning from what it sees;
* :mod:`.goal_belief` and :mod:`.apollonius`: where the goal can be when the picture does not show it (the task's
  goal distribution, what the picture rules out, the circles the rewards put it on);
* :mod:`.sysid`: ``phyplan-perception-sysid``, perception plus identification of the hidden physics from rewards.

The camera's calibration comes from the env (:meth:`phyplan_envs.base.PhyPlanEnv.camera_model`); nothing here reads
the simulator's state.
"""
from .scene import Percept, PerceptionError, perceive

__all__ = ["Percept", "PerceptionError", "perceive"]
