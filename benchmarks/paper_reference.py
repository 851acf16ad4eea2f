"""The PhyPlan paper's logged results, shown beside ours in the benchmark summary (for reference only).

Source: ``docs/reference-values.md``, "Results logged in their code": mean regret over 10 contexts after 1
and after 5 attempts, read from the authors' public code for the Isaac Gym version of the tasks. The PhyPlan column
is "PhyPlan without perception" (goal and object positions from the simulator, as our state observations give).
The Launch value after one attempt is approximate in the source ("≈ .13"). These are different physics (Isaac Gym,
other goal samplers), so they are a reference point, not a like-for-like comparison.
"""
from __future__ import annotations

PAPER_CONTEXTS = 10
"""Number of contexts the paper's logged means are over."""

PAPER_REGRET: dict[str, dict[str, tuple[float, float]]] = {
    "launch": {"phyplan": (0.13, 0.085), "dqn-adapted": (0.43, 0.28), "dqn-simple": (0.59, 0.42),
               "random": (0.69, 0.49)},
    "slide": {"phyplan": (0.142, 0.100), "dqn-adapted": (0.29, 0.09), "dqn-simple": (0.19, 0.155),
              "random": (0.74, 0.32)},
    "bounce": {"phyplan": (0.205, 0.105), "dqn-adapted": (0.39, 0.205), "dqn-simple": (0.40, 0.355),
               "random": (0.75, 0.46)},
    "bridge": {"phyplan": (0.152, 0.111), "dqn-adapted": (0.30, 0.27), "dqn-simple": (0.32, 0.275),
               "random": (0.66, 0.40)},
}
"""task -> our agent name -> (mean regret after 1 attempt, after 5 attempts)."""

PAPER_ATTEMPTS = (1, 5)
"""The attempt counts the two numbers of :data:`PAPER_REGRET` belong to."""

APPROXIMATE = {("launch", "phyplan")}
"""Entries whose first number the source gives only approximately."""


def paper_regret(task: str, agent: str) -> tuple[float, float] | None:
    """The paper's (regret after 1, after 5 attempts) for a task and agent name, or None if it has none."""
    return PAPER_REGRET.get(task, {}).get(agent)


def _fmt(v: float) -> str:
    """``.085``, ``.10``, ``.43``: at least two decimals, no leading zero (as the source writes them)."""
    text = f"{v:.3f}"
    if text.endswith("0"):
        text = text[:-1]
    return text[1:] if text.startswith("0.") else text


def format_paper(task: str, agent: str) -> str:
    """``".13 → .085"`` style text for tables ("" if the paper has no number for this pair)."""
    ref = paper_regret(task, agent)
    if ref is None:
        return ""
    a, b = (_fmt(v) for v in ref)
    return ("≈" if (task, agent) in APPROXIMATE else "") + f"{a} → {b}"
