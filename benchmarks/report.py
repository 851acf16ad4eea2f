"""Summaries of benchmark records: regret curves with 95% CIs, area under the curve, success, runtime; tables, plots.

Definitions (per task and agent, over the cells = run seeds x contexts):

* **Regret after k attempts** of a cell: ``max(0, 1 - best)`` with ``best`` the best reward of attempts ``1..k`` that
  ran; 1.0 while none has run (failed attempts do not change it). It is recomputed here from the rewards, not read
  from the records' ``regret`` field.
* **Mean regret and its 95% CI** at each k: the cells of each context are first averaged over run seeds, then a
  Student-t interval is taken over contexts, ``mean ± t(0.975, n-1) · sd / sqrt(n)`` with n the number of contexts.
  Contexts, not seeds, are the independent units (the seeds of one context share its difficulty), so this interval
  is wider, and more honest, than one over all cells. With one context there is no interval (shown as "–").
* **AUC (area under the regret curve)**: ``sum_k w_k · regret_k / sum_k w_k`` with PHYRE's AUCCESS weights
  ``w_k = log(k+1) - log(k)`` for ``k = 1..K`` (Bakhtin et al., 2019), which weigh early attempts most; 0 is best.
  With K = 5 the normalised weights are .387, .226, .161, .124, .102.
* **AUCCESS**: the same weighted area of the success-rate curve (share of cells whose object landed in the goal box
  within k attempts); 1 is best.
* **Success rate**: share of cells solved (goal box) within all K attempts.
* **Runtime per attempt**: the agent's own time (``begin_context`` + ``act`` + ``observe``) per attempt, and the
  env's time for the real attempt (reset + step), in seconds; plus simulator calls and skill evaluations per
  attempt.

The oracle (and any agent the run lists as a bound) is marked "(bound)" and listed last in each task.
"""
from __future__ import annotations

import argparse
import csv
import math
import sys
from collections import OrderedDict
from dataclasses import dataclass, field
from pathlib import Path
from typing import Iterable, Mapping, Sequence

import numpy as np

from . import compare, paper_reference
from .harness import RECORDS_NAME, AttemptRecord, load_records, read_config
from .platform_info import describe, read_platforms
from .stats import mean_ci, per_context  # noqa: F401  (mean_ci is also this module's public name)


def auc_weights(k: int) -> np.ndarray:
    """PHYRE's AUCCESS weights ``w_j = log(j+1) - log(j)``, ``j = 1..k``, normalised to sum to 1."""
    if isinstance(k, bool) or not isinstance(k, (int, np.integer)) or k < 1:
        raise ValueError(f"k must be a positive integer, got {k!r}")
    j = np.arange(1, int(k) + 1, dtype=np.float64)
    w = np.log(j + 1) - np.log(j)
    return w / w.sum()


def weighted_area(curve: Sequence[float]) -> float:
    """The AUCCESS-weighted mean of a curve over attempts 1..K (:func:`auc_weights`)."""
    c = np.asarray(curve, dtype=np.float64)
    return float(np.dot(auc_weights(len(c)), c))


def regret_curve(rewards: Sequence[float | None]) -> np.ndarray:
    """Regret after each attempt from the attempts' rewards (None = failed attempt; see the module docstring)."""
    out = np.empty(len(rewards), dtype=np.float64)
    best = None
    for i, r in enumerate(rewards):
        if r is not None:
            best = r if best is None else max(best, r)
        out[i] = 1.0 if best is None else max(0.0, 1.0 - best)
    return out


@dataclass
class AgentSummary:
    """The summary of one agent on one task (one row of ``summary.csv``)."""

    task: str
    agent: str
    is_bound: bool
    n_cells: int
    n_contexts: int
    n_seeds: int
    attempts: int
    regret: list[float]                 # mean regret after k = 1..K attempts
    regret_low: list[float]             # 95% CI
    regret_high: list[float]
    success: list[float]                # share of cells solved within k attempts
    auc: float                          # weighted area under the regret curve (lower is better)
    auc_low: float
    auc_high: float
    auccess: float                      # weighted area under the success curve (higher is better)
    success_rate: float                 # = success[-1]
    agent_time: float                   # s per attempt (begin_context + act + observe)
    env_time: float                     # s per attempt (env reset + step)
    sim_calls: float                    # per attempt
    skill_evals: float                  # per attempt
    failed: int                         # attempts with an error (the agent raised or gave a bad action)
    failure_example: str = ""
    training: dict = field(default_factory=dict)
    paper: tuple[float, float] | None = None

    @property
    def label(self) -> str:
        return f"{self.agent} (bound)" if self.is_bound else self.agent


def summarize(records: Iterable[AttemptRecord], attempts: int | None = None,
              bound_agents: Iterable[str] = ("oracle",), order: Sequence[str] | None = None,
              task_order: Sequence[str] | None = None) -> list[AgentSummary]:
    """Summaries per (task, agent) of finished cells' records.

    The result does not depend on the order of the records (parallel runs write cells in any order): they are
    sorted by (task, agent, seed, context, attempt) first, so every floating-point sum is taken in the same order.

    Args:
        records: attempt records (e.g. from :func:`benchmarks.harness.load_records`).
        attempts: K; default: the largest attempt number in the records. Cells without all K attempts raise.
        bound_agents: agents to mark as the bound (listed last within each task).
        order: agent order for the output (default: alphabetical); task_order likewise for tasks.
    """
    records = sorted(records, key=lambda r: (r.task, r.agent, r.seed, r.context, r.attempt))
    if not records:
        return []
    k_max = attempts or max(r.attempt for r in records)
    bounds = set(bound_agents)
    cells: "OrderedDict[tuple, dict[int, AttemptRecord]]" = OrderedDict()
    for r in records:
        cells.setdefault(r.cell, {})[r.attempt] = r
    groups: "OrderedDict[tuple[str, str], list[dict[int, AttemptRecord]]]" = OrderedDict()
    for (task, agent, _, _), recs in cells.items():
        if set(recs) != set(range(1, k_max + 1)):
            raise ValueError(f"cell {task}/{agent} has attempts {sorted(recs)}, expected 1..{k_max}")
        groups.setdefault((task, agent), []).append(recs)

    out = []
    for (task, agent), cell_list in groups.items():
        seeds = sorted({c[1].seed for c in cell_list})
        reg = np.array([regret_curve([c[k].reward for k in range(1, k_max + 1)]) for c in cell_list])
        suc = np.array([np.maximum.accumulate([bool(c[k].success) for k in range(1, k_max + 1)])
                        for c in cell_list], dtype=np.float64)
        ctx_ids, reg_ctx = per_context(reg, [c[1].context for c in cell_list])
        mean, lo, hi = mean_ci(reg_ctx)
        w = auc_weights(k_max)
        auc_m, auc_lo, auc_hi = mean_ci(reg_ctx @ w)
        all_recs = [r for c in cell_list for r in c.values()]
        failed = [r for r in all_recs if r.failed]
        out.append(AgentSummary(
            task=task, agent=agent, is_bound=agent in bounds, n_cells=len(cell_list), n_contexts=len(ctx_ids),
            n_seeds=len(seeds), attempts=k_max, regret=mean.tolist(), regret_low=lo.tolist(),
            regret_high=hi.tolist(), success=suc.mean(axis=0).tolist(), auc=float(auc_m), auc_low=float(auc_lo),
            auc_high=float(auc_hi), auccess=float(suc.mean(axis=0) @ w), success_rate=float(suc[:, -1].mean()),
            agent_time=float(np.mean([r.begin_time + r.act_time + r.observe_time for r in all_recs])),
            env_time=float(np.mean([r.step_time for r in all_recs])),
            sim_calls=float(np.mean([r.sim_calls for r in all_recs])),
            skill_evals=float(np.mean([r.skill_evals for r in all_recs])),
            failed=len(failed), failure_example=failed[0].error if failed else "",
            training=dict(cell_list[0][1].training), paper=paper_reference.paper_regret(task, agent)))

    task_rank = {t: i for i, t in enumerate(task_order or ())}
    rank = {a: i for i, a in enumerate(order or ())}
    out.sort(key=lambda s: (task_rank.get(s.task, len(task_rank)), s.task, s.is_bound,
                            rank.get(s.agent, len(rank)), s.agent))
    return out


# ========================================================================================================= tables
def _f(x: float, digits: int = 3) -> str:
    return "–" if x is None or not math.isfinite(x) else f"{x:.{digits}f}"


def _ci(m: float, lo: float, hi: float) -> str:
    if not math.isfinite(lo):
        return _f(m)
    return f"{_f(m)} ± {_f((hi - lo) / 2)}"


def _time(s: float) -> str:
    if s >= 1:
        return f"{s:.2f} s"
    if s >= 1e-3:
        return f"{s * 1e3:.1f} ms"
    return f"{s * 1e6:.0f} µs"


def format_markdown(summaries: Sequence[AgentSummary], title: str = "Benchmark summary",
                    config: Mapping | None = None) -> str:
    """The summary as Markdown: the main table, regret by attempt, and failures if any."""
    if not summaries:
        return f"# {title}\n\nNo finished cells yet.\n"
    k = summaries[0].attempts
    lines = [f"# {title}", ""]
    if config:
        lines += [f"Split `{config.get('split')}`, {config.get('contexts')} contexts × {config.get('seeds')} "
                  f"run seeds per task and agent, {k} attempts per context. Regret = max(0, 1 − best reward); "
                  f"± is the half-width of a 95% Student-t interval over contexts. AUC = area under the regret "
                  f"curve with PHYRE's AUCCESS weights w_k = log(k+1) − log(k) (lower is better). "
                  f"Paper: the PhyPlan paper's logged mean regret after 1 → 5 attempts (10 contexts, Isaac Gym; "
                  f"for reference only).", ""]
    mid = [5] if 1 < 5 < k else []           # the varied track (10 attempts) also shows regret@5
    head = ["task", "agent", "cells", "regret@1"] + [f"regret@{i}" for i in mid] + [f"regret@{k}", "AUC regret",
            f"success@{k}", "AUCCESS",
            "agent time/attempt", "env time/attempt", "sim calls/attempt", "skill evals/attempt", "failed",
            "paper regret @1 → @5"]
    lines += ["| " + " | ".join(head) + " |", "|" + "---|" * len(head)]
    for s in summaries:
        row = [s.task, f"**{s.label}**" if s.is_bound else s.label, str(s.n_cells),
               _ci(s.regret[0], s.regret_low[0], s.regret_high[0]),
               *[_ci(s.regret[i - 1], s.regret_low[i - 1], s.regret_high[i - 1]) for i in mid],
               _ci(s.regret[-1], s.regret_low[-1], s.regret_high[-1]), _ci(s.auc, s.auc_low, s.auc_high),
               _f(s.success_rate, 2), _f(s.auccess), _time(s.agent_time), _time(s.env_time), _f(s.sim_calls, 1),
               _f(s.skill_evals, 0), str(s.failed), paper_reference.format_paper(s.task, s.agent)]
        lines.append("| " + " | ".join(row) + " |")
    lines += ["", "## Mean regret by attempt (± 95% CI)", ""]
    head = ["task", "agent"] + [f"k={i}" for i in range(1, k + 1)]
    lines += ["| " + " | ".join(head) + " |", "|" + "---|" * len(head)]
    for s in summaries:
        cells = [_ci(m, lo, hi) for m, lo, hi in zip(s.regret, s.regret_low, s.regret_high)]
        lines.append("| " + " | ".join([s.task, s.label] + cells) + " |")
    failures = [s for s in summaries if s.failed]
    if failures:
        lines += ["", "## Failed attempts", ""]
        for s in failures:
            lines.append(f"- {s.task} / {s.agent}: {s.failed} failed attempt(s), e.g. `{s.failure_example}`")
    return "\n".join(lines) + "\n"


def write_csv(summaries: Sequence[AgentSummary], path: str | Path) -> None:
    """One row per task and agent; per-attempt columns ``regret_k``, ``regret_k_low``, ``regret_k_high``,
    ``success_k``."""
    path = Path(path)
    k = summaries[0].attempts if summaries else 0
    head = ["task", "agent", "is_bound", "cells", "contexts", "seeds", "attempts", "auc_regret", "auc_regret_low",
            "auc_regret_high", "auccess", "success_rate", "agent_time_s", "env_time_s", "sim_calls_per_attempt",
            "skill_evals_per_attempt", "failed_attempts", "paper_regret_1", "paper_regret_5"]
    for i in range(1, k + 1):
        head += [f"regret_{i}", f"regret_{i}_low", f"regret_{i}_high", f"success_{i}"]
    with open(path, "w", newline="") as f:
        w = csv.writer(f)
        w.writerow(head)
        for s in summaries:
            row = [s.task, s.agent, int(s.is_bound), s.n_cells, s.n_contexts, s.n_seeds, s.attempts, s.auc,
                   s.auc_low, s.auc_high, s.auccess, s.success_rate, s.agent_time, s.env_time, s.sim_calls,
                   s.skill_evals, s.failed, *(s.paper if s.paper else ("", ""))]
            for i in range(k):
                row += [s.regret[i], s.regret_low[i], s.regret_high[i], s.success[i]]
            w.writerow(["" if isinstance(v, float) and not math.isfinite(v) else v for v in row])


# ========================================================================================================== plots
def plot_regret(summaries: Sequence[AgentSummary], out_dir: str | Path) -> list[Path]:
    """One PNG per task, ``regret_<task>.png``: mean regret vs attempts with 95% bands (like the paper's Fig. 7).

    The oracle bound is dashed; the paper's logged numbers (after 1 and 5 attempts) are hollow markers in the same
    colour as the agent.
    """
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    out = []
    agents = list(OrderedDict.fromkeys(s.agent for s in summaries))
    colors = {a: plt.get_cmap("tab10")(i % 10) for i, a in enumerate(agents)}
    for task in OrderedDict.fromkeys(s.task for s in summaries):
        fig, ax = plt.subplots(figsize=(7.4, 3.8), dpi=120)
        for s in (s for s in summaries if s.task == task):
            k = np.arange(1, s.attempts + 1)
            c = colors[s.agent]
            ax.plot(k, s.regret, "--" if s.is_bound else "-", marker="o", ms=3.5, color=c, label=s.label)
            lo, hi = np.asarray(s.regret_low), np.asarray(s.regret_high)
            if np.all(np.isfinite(lo)):
                ax.fill_between(k, lo, hi, color=c, alpha=0.15, linewidth=0)
            if s.paper is not None:
                xs = [a for a in paper_reference.PAPER_ATTEMPTS if a <= s.attempts]
                ax.plot(xs, s.paper[: len(xs)], linestyle="none", marker="s", mfc="none", color=c, ms=6)
        if any(s.paper for s in summaries if s.task == task):
            ax.plot([], [], linestyle="none", marker="s", mfc="none", color="grey", label="paper (logged)")
        ax.set_title(f"{task.capitalize()}: regret vs attempts")
        ax.set_xlabel("attempts")
        ax.set_ylabel("mean regret (95% CI)")
        ax.set_xticks(np.arange(1, summaries[0].attempts + 1))
        ax.set_ylim(bottom=0)
        ax.grid(alpha=0.3)
        ax.legend(fontsize=7, loc="upper left", bbox_to_anchor=(1.01, 1.0), borderaxespad=0)
        fig.tight_layout()
        path = Path(out_dir) / f"regret_{task}.png"
        fig.savefig(path)
        plt.close(fig)
        out.append(path)
    return out


def plot_runtime(summaries: Sequence[AgentSummary], out_dir: str | Path) -> Path:
    """``runtime.png``: the agent's time per attempt (log scale), grouped by task (like the paper's Fig. 9)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    tasks = list(OrderedDict.fromkeys(s.task for s in summaries))
    agents = list(OrderedDict.fromkeys(s.agent for s in summaries))
    by = {(s.task, s.agent): s for s in summaries}
    width = 0.8 / max(1, len(agents))
    fig, ax = plt.subplots(figsize=(4.2 + 1.3 * len(tasks), 3.8), dpi=120)
    for i, a in enumerate(agents):
        xs, ys = [], []
        for j, t in enumerate(tasks):
            if (t, a) in by:
                xs.append(j + (i - (len(agents) - 1) / 2) * width)
                ys.append(max(by[(t, a)].agent_time, 1e-6))
        label = by[next(k for k in by if k[1] == a)].label
        ax.bar(xs, ys, width=width, color=plt.get_cmap("tab10")(i % 10), label=label)
    ax.set_yscale("log")
    ax.set_xticks(range(len(tasks)))
    ax.set_xticklabels([t.capitalize() for t in tasks])
    ax.set_ylabel("agent time per attempt (s)")
    ax.set_title("Agent time per attempt (the real attempt excluded)", fontsize=10)
    ax.grid(axis="y", alpha=0.3)
    ax.legend(fontsize=7, loc="upper left", bbox_to_anchor=(1.01, 1.0), borderaxespad=0)
    fig.tight_layout()
    path = Path(out_dir) / "runtime.png"
    fig.savefig(path)
    plt.close(fig)
    return path


def write_report(records: Sequence[AttemptRecord], out_dir: str | Path, config: Mapping | None = None,
                 plots: bool = True) -> tuple[list[AgentSummary], str]:
    """Write ``summary.md``, ``summary.csv`` and the plots into ``out_dir``; return the summaries and the Markdown."""
    config = dict(config or {})
    summaries = summarize(records, attempts=config.get("attempts"), bound_agents=config.get("bound_agents", ["oracle"]),
                          order=config.get("agents"), task_order=config.get("tasks"))
    text = format_markdown(summaries, config=config or None)
    out = Path(out_dir)
    platforms = read_platforms(out)
    if platforms:
        text += "\nMade on: " + "; ".join(describe(p) for p in platforms) + "\n"
    (out / "summary.md").write_text(text)
    write_csv(summaries, out / "summary.csv")
    if plots and summaries:
        plot_regret(summaries, out)
        plot_runtime(summaries, out)
    return summaries, text


def main(argv: Sequence[str] | None = None) -> int:
    """``python -m benchmarks.report DIR``: rewrite the summary and plots of a benchmark directory;
    ``python -m benchmarks.report --compare DIR_A DIR_B``: compare two of them (:mod:`benchmarks.compare`)."""
    p = argparse.ArgumentParser(prog="python -m benchmarks.report", description=main.__doc__)
    p.add_argument("dir", nargs="?", help="a benchmark output directory (with config.json and attempts.jsonl)")
    p.add_argument("--no-plots", action="store_true", help="skip the PNGs")
    p.add_argument("--compare", nargs=2, metavar=("DIR_A", "DIR_B"),
                   help="print two directories' tables side by side, each row's difference in units of the combined "
                        "95%% interval, and both platforms; exit 1 if a row differs by more than --threshold units")
    p.add_argument("--threshold", type=float, default=compare.DEFAULT_THRESHOLD,
                   help="with --compare: the largest |difference| in interval units that still passes (default: "
                        "%(default)s)")
    args = p.parse_args(argv)
    if args.compare:
        if args.dir is not None:
            p.error("give either DIR or --compare DIR_A DIR_B, not both")
        return compare.main_compare(args.compare, args.threshold, p.error)
    if args.dir is None:
        p.error("a benchmark directory DIR (or --compare DIR_A DIR_B) is required")
    try:
        config = read_config(args.dir)
    except (FileNotFoundError, ValueError) as exc:
        p.error(str(exc))
    try:
        records, dropped = load_records(Path(args.dir) / RECORDS_NAME, config.attempts)
    except ValueError as exc:      # DamagedRecords: names the lines and the way to repair
        print(f"{p.prog}: error: {exc}", file=sys.stderr)
        return 1
    if dropped:
        print(f"note: {dropped} records of unfinished cells ignored", file=sys.stderr)
    _, text = write_report(records, args.dir, config.to_dict(), plots=not args.no_plots)
    print(text)
    return 0


if __name__ == "__main__":
    sys.exit(main())
