"""The PhyPlan agent: batched skill-chain rollouts, physics-informed MCTS and GP-UCB adaptation.

Modules: :mod:`.queries` (event queries of time-parameterised skill models), :mod:`.composer` (each task's skill
chain, composed from the scene the task describes; :mod:`.geometry` its geometry), :mod:`.predictor` (a chain as a batched
reward predictor for one context), :mod:`.mcts` (Algorithm 1 and the local refinement), GP-UCB (Algorithm 2) in
:mod:`phyplan_agents.gp_ucb`, and :mod:`.agent` (the registered agents ``phyplan``, ``phyplan-nogp``,
``phyplan-sim``).
"""
from ..gp_ucb import ResidualGP
from .agent import PhyPlanAgent, PhyPlanNoGPAgent, PhyPlanPositionAgent, PhyPlanSimAgent
from .composer import Chain, chain_for
from .mcts import MCTS, refine
from .predictor import ChainPredictor

__all__ = ["Chain", "ChainPredictor", "MCTS", "PhyPlanAgent", "PhyPlanNoGPAgent", "PhyPlanPositionAgent",
           "PhyPlanSimAgent",
           "ResidualGP", "chain_for", "refine"]
