"""The tools a task is assembled from: each builds its MJCF piece, looks up its parts and applies its own actions.

A task (:mod:`phyplan_envs.tasks`) lists its tools in :meth:`~phyplan_envs.base.PhyPlanEnv.assemble`, in the order
they are built into the scene (the order of the bodies in the model); the env holds them as an :class:`Assembly`
(``env.tools``), which calls, on every tool in that order:

* ``build(root)`` (the MJCF piece, from the :mod:`phyplan_envs.assets` builders), and in robot mode
  ``robot_scene(root)`` (what the arm needs, e.g. a pivot for a tool it turns);
* ``bind(scene)`` after compiling (the ids of its parts, named access through :class:`phyplan_envs.scene.Scene`);
* ``reset()`` at every reset (its pose between attempts);
* ``apply(values)`` in the kinematic set-up, and in robot mode ``robot_steps(values)`` (the arm's
  :class:`~phyplan_envs.panda.robot.paths.Carry` steps, the tool's other settings made directly): ``values`` are the
  tool's own action dimensions (:attr:`Tool.dims`, by name, as float64).

The tools: :class:`PendulumRig` (the pendulum that hits an object at rest), :class:`Ball`, :class:`DropBall` and
:class:`Puck` (the moving objects; the puck a disc or the block that faces the swing plane), :class:`Pedestal`,
:class:`Table`, :class:`RoundTable`, :class:`Wedge`, :class:`PlacedWedge` (a wedge on the ground that
the action places), :class:`Plank`, :class:`GoalBox` and :class:`PandaStand`; Paddles' :class:`~.paddles.Shelf` and
:class:`~.paddles.Paddle` (:mod:`.paddles`);
:func:`polar_goal` is the goal sampler of the tasks whose goals lie in a ring sector around the object.
"""
from __future__ import annotations

from .objects import Ball, DropBall, Puck
from .pendulum import PENDULUM_DIMS, Pendulum, PendulumFacts, PendulumRig
from .supports import (GoalBox, PandaStand, Pedestal, PlacedWedge, Plank, RoundTable, Table, Wedge,
                       placed_wedge_dims, polar, polar_goal)
from .tool import Assembly, Tool

__all__ = ["Assembly", "Ball", "DropBall", "GoalBox", "PENDULUM_DIMS", "PandaStand", "Pedestal", "Pendulum",
           "PendulumFacts", "PendulumRig", "PlacedWedge", "Plank", "Puck", "RoundTable", "Table", "Tool", "Wedge",
           "placed_wedge_dims", "polar", "polar_goal"]
