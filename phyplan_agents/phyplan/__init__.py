"""The PhyPlan agent: batched skill-chain rollouts, physics-informed MCTS and GP-UCB adaptation (issue 6).

Modules: :mod:`.queries` (event queries of time-parameterised skill models), :mod:`.chain` (a task's skill chain
as a batched reward predictor), :mod:`.mcts` (Algorithm 1 and the local refinement), :mod:`.gp` (GP-UCB,
Algorithm 2) and :mod:`.agent` (the registered agents ``phyplan``, ``phyplan-nogp``, ``phyplan-sim``).
"""
from .agent import PhyPlanAgent, PhyPlanNoGPAgent, PhyPlanSimAgent
from .chain import SkillChain
from ..gp_ucb import ResidualGP
from .mcts import MCTS, refine

__all__ = ["MCTS", "PhyPlanAgent", "PhyPlanNoGPAgent", "PhyPlanSimAgent", "ResidualGP", "SkillChain", "refine"]
