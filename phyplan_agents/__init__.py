"""phyplan agents: one protocol (:mod:`phyplan_agents.base`), a registry, and the agent zoo."""
from .base import Agent, Simulator, TaskInfo
from .registry import available, make, register, resolve

__all__ = ["Agent", "Simulator", "TaskInfo", "available", "make", "register", "resolve"]
