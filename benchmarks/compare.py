"""Two results tables side by side: ``python -m benchmarks.report --compare DIR_A DIR_B``.

For each row (task, agent) present in both directories it prints the mean regret after the last attempt and the
area under the regret curve of each, and their difference in units of the combined 95% interval::

    z = (mean_A - mean_B) / sqrt(half_A ** 2 + half_B ** 2)

with ``half`` the half-width of each table's 95% Student-t interval over contexts (:mod:`benchmarks.report`). |z|
below 1 means the two tables agree within their intervals; a row with one context has no interval, and there any
difference counts as infinitely many units. Both directories' platforms (``platform.json``,
:mod:`benchmarks.platform_info`) are printed above the table. The command exits 1 when some row's |z| exceeds
``--threshold`` (default 1: a difference beyond the combined 95% interval) or the two tables share no row, else 0.
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path
from typing import Sequence

from .harness import RECORDS_NAME, load_records, read_config
from .platform_info import describe, read_platforms

DEFAULT_THRESHOLD = 1.0


@dataclass(frozen=True)
class RowDiff:
    """One (task, agent) row of two tables: each table's value and interval half-width, and their difference in units
    of the combined interval, for the final regret and for the AUC."""

    task: str
    agent: str
    regret: tuple[float, float]
    regret_half: tuple[float, float]
    auc: tuple[float, float]
    auc_half: tuple[float, float]

    @staticmethod
    def units(a: float, b: float, half_a: float, half_b: float) -> float:
        """``(a - b) / sqrt(half_a**2 + half_b**2)``; 0 for equal values, +-inf for different values without an
        interval (one context)."""
        if a == b:
            return 0.0
        width = math.hypot(half_a, half_b) if math.isfinite(half_a) and math.isfinite(half_b) else 0.0
        return (a - b) / width if width > 0 else math.copysign(math.inf, a - b)

    @property
    def regret_units(self) -> float:
        return self.units(*self.regret, *self.regret_half)

    @property
    def auc_units(self) -> float:
        return self.units(*self.auc, *self.auc_half)

    @property
    def worst(self) -> float:
        return max(abs(self.regret_units), abs(self.auc_units))


def _summaries(out_dir: str | Path):
    from .report import summarize

    config = read_config(out_dir)
    records, _ = load_records(Path(out_dir) / RECORDS_NAME, config.attempts)
    return {(s.task, s.agent): s for s in summarize(records, attempts=config.attempts,
                                                   bound_agents=config.bound_agents, order=config.agents,
                                                   task_order=config.tasks)}


def _half(mean: float, low: float, high: float) -> float:
    return (high - low) / 2 if math.isfinite(low) and math.isfinite(high) else math.nan


def compare_dirs(dir_a: str | Path, dir_b: str | Path) -> tuple[list[RowDiff], list[tuple[str, str]],
                                                               list[tuple[str, str]]]:
    """The rows both tables have, and the (task, agent) rows only in A and only in B."""
    a, b = _summaries(dir_a), _summaries(dir_b)
    rows = []
    for key in [k for k in a if k in b]:
        sa, sb = a[key], b[key]
        rows.append(RowDiff(
            task=key[0], agent=key[1], regret=(sa.regret[-1], sb.regret[-1]),
            regret_half=(_half(sa.regret[-1], sa.regret_low[-1], sa.regret_high[-1]),
                         _half(sb.regret[-1], sb.regret_low[-1], sb.regret_high[-1])),
            auc=(sa.auc, sb.auc), auc_half=(_half(sa.auc, sa.auc_low, sa.auc_high),
                                            _half(sb.auc, sb.auc_low, sb.auc_high))))
    return rows, [k for k in a if k not in b], [k for k in b if k not in a]


def _num(x: float) -> str:
    return "–" if not math.isfinite(x) else f"{x:.3f}"


def _units(x: float) -> str:
    return ("+inf" if x > 0 else "-inf") if math.isinf(x) else f"{x:+.2f}"


def format_comparison(dir_a: str | Path, dir_b: str | Path, threshold: float = DEFAULT_THRESHOLD) -> tuple[str, bool]:
    """The comparison as Markdown, and whether every shared row is within ``threshold`` units (and one is shared)."""
    rows, only_a, only_b = compare_dirs(dir_a, dir_b)
    lines = [f"# Comparison: A = {dir_a}, B = {dir_b}", ""]
    for name, d in (("A", dir_a), ("B", dir_b)):
        platforms = read_platforms(d)
        lines += [f"- platform {name}: " + ("; ".join(describe(p) for p in platforms) if platforms
                                             else "not recorded (made before platforms were recorded)")]
    lines += ["", f"Differences in units of the combined 95% interval (|units| > {threshold:g} is flagged).", "",
              "| task | agent | regret A | ± | regret B | ± | units | AUC A | AUC B | units | |",
              "|---|---|---|---|---|---|---|---|---|---|---|"]
    for r in rows:
        flag = "**beyond**" if r.worst > threshold else ""
        lines.append(f"| {r.task} | {r.agent} | {_num(r.regret[0])} | {_num(r.regret_half[0])} | {_num(r.regret[1])} "
                     f"| {_num(r.regret_half[1])} | {_units(r.regret_units)} | {_num(r.auc[0])} | {_num(r.auc[1])} "
                     f"| {_units(r.auc_units)} | {flag} |")
    for name, keys in (("A", only_a), ("B", only_b)):
        if keys:
            lines += ["", f"Only in {name}: " + ", ".join(f"{t}/{a}" for t, a in keys)]
    ok = bool(rows) and all(r.worst <= threshold for r in rows)
    worst = max((r.worst for r in rows), default=math.nan)
    lines += ["", f"Largest difference: {_units(worst) if rows else 'no shared row'} units; "
              + ("within" if ok else "NOT within") + f" the threshold {threshold:g}."]
    return "\n".join(lines) + "\n", ok


def main_compare(dirs: Sequence[str], threshold: float, error) -> int:
    """The ``--compare`` branch of ``python -m benchmarks.report``; ``error`` reports a usage error (exits 2)."""
    if not (threshold > 0 and math.isfinite(threshold)):
        error(f"--threshold must be a positive number, got {threshold!r}")
    for d in dirs:
        try:
            read_config(d)
        except (FileNotFoundError, ValueError) as exc:
            error(f"--compare {d}: {exc}")
    text, ok = format_comparison(*dirs, threshold=threshold)
    print(text)
    return 0 if ok else 1
