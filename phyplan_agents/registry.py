"""Agents by name: built-in ones, third-party ones from the ``phyplan.agents`` entry-point group, or
``"module:Class"`` strings.

>>> import phyplan_agents
>>> agent = phyplan_agents.make("random")
"""
from __future__ import annotations

import importlib
from importlib import metadata
from typing import Any

from .base import Agent

ENTRY_POINT_GROUP = "phyplan.agents"

# name -> "module:attribute" (imported lazily, so that `make("random")` does not import torch or SB3)
_BUILTIN: dict[str, str] = {
    "random": "phyplan_agents.random_agent:RandomAgent",
    "oracle": "phyplan_agents.oracle:OracleAgent",
    "dqn-simple": "phyplan_agents.dqn.agents:DQNSimpleAgent",
    "dqn-adapted": "phyplan_agents.dqn.agents:DQNAdaptedAgent",
    "phyplan": "phyplan_agents.phyplan.agent:PhyPlanAgent",
    "phyplan-nogp": "phyplan_agents.phyplan.agent:PhyPlanNoGPAgent",
    "phyplan-position": "phyplan_agents.phyplan.agent:PhyPlanPositionAgent",
    "phyplan-sysid": "phyplan_agents.phyplan.sysid:PhyPlanSysIdAgent",
    "phyplan-sim": "phyplan_agents.phyplan.agent:PhyPlanSimAgent",
    "phyplan-perception": "phyplan_agents.perception.agent:PhyPlanPerceptionAgent",
    "phyplan-perception-sysid": "phyplan_agents.perception.sysid:PhyPlanPerceptionSysIdAgent",
}
_REGISTERED: dict[str, Any] = {}


def register(name: str, target: Any) -> None:
    """Register an agent class (or a ``"module:Class"`` string) under ``name``."""
    if not name or not isinstance(name, str):
        raise ValueError("agent name must be a non-empty string")
    _REGISTERED[name] = target


def _entry_points() -> dict[str, Any]:
    try:
        eps = metadata.entry_points(group=ENTRY_POINT_GROUP)
    except TypeError:  # pragma: no cover - very old importlib.metadata
        eps = metadata.entry_points().get(ENTRY_POINT_GROUP, [])
    return {ep.name: ep for ep in eps}


def available() -> list[str]:
    """Every agent name that :func:`make` accepts (besides ``module:Class`` strings)."""
    return sorted(set(_BUILTIN) | set(_REGISTERED) | set(_entry_points()))


def _load(target: Any) -> Any:
    if isinstance(target, metadata.EntryPoint):
        return target.load()
    if isinstance(target, str):
        module_name, _, attr = target.partition(":")
        if not attr:
            raise ValueError(f"agent spec {target!r} must look like 'package.module:ClassName'")
        try:
            module = importlib.import_module(module_name)
        except ImportError as exc:
            raise ValueError(f"cannot import module {module_name!r} for agent {target!r}: {exc}") from exc
        try:
            return getattr(module, attr)
        except AttributeError:
            raise ValueError(f"module {module_name!r} has no attribute {attr!r} (agent {target!r})") from None
    return target


def resolve(name: str) -> Any:
    """The agent class (or factory) for a name, without instantiating it."""
    if name in _REGISTERED:
        return _load(_REGISTERED[name])
    if name in _BUILTIN:
        return _load(_BUILTIN[name])
    eps = _entry_points()
    if name in eps:
        return _load(eps[name])
    if ":" in name:
        return _load(name)
    raise ValueError(f"unknown agent {name!r}; available agents: {', '.join(available())} "
                     f"(or give 'package.module:ClassName')")


def make(name: str, **kwargs: Any) -> Agent:
    """Instantiate an agent by registry name, entry-point name or ``"module:Class"`` string."""
    factory = resolve(name)
    agent = factory(**kwargs)
    if not isinstance(agent, Agent):
        for method in ("setup", "begin_context", "act", "observe"):
            if not callable(getattr(agent, method, None)):
                raise TypeError(f"agent {name!r} does not implement the protocol: missing {method}()")
    return agent
