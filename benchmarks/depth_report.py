"""The figures of :mod:`benchmarks.depth` (its ``--json`` results, per N and section) as markdown tables and as the
figure (regret after 5 attempts, landing error and time per decision against N)."""
from __future__ import annotations


def plot(results: dict, path: str) -> None:
    """The figure of ``results`` to ``path`` (PNG): regret after 5 attempts, the chain's landing error and the
    first decision's CPU time, each against N."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    depths = sorted(int(n) for n in results)
    fig, axes = plt.subplots(1, 3, figsize=(13, 3.8))
    agents = sorted({a for n in depths for a in results[str(n)].get("regret", {})})
    for a in agents:
        ns = [n for n in depths if a in results[str(n)].get("regret", {})]
        r = [results[str(n)]["regret"][a]["regret5"] for n in ns]
        hw = [results[str(n)]["regret"][a]["regret5_hw"] for n in ns]
        axes[0].errorbar(ns, r, yerr=hw, marker="o", capsize=3, label=a)
    axes[0].set(xlabel="paddles N", ylabel="regret after 5 attempts", title="Regret vs chain depth")
    axes[0].set_yscale("symlog", linthresh=0.01)       # linear below 0.01: the planners' regrets, then random's
    axes[0].legend(fontsize=8)
    ns = [n for n in depths if "accuracy" in results[str(n)]]
    axes[1].plot(ns, [100 * results[str(n)]["accuracy"]["mean_m"] for n in ns], marker="o", label="mean")
    axes[1].plot(ns, [100 * results[str(n)]["accuracy"]["p90_m"] for n in ns], marker="s", label="p90")
    axes[1].set(xlabel="paddles N", ylabel="landing error (cm)", title="Composed chain vs simulator")
    axes[1].legend(fontsize=8)
    ns = [n for n in depths if "decision" in results[str(n)]]
    axes[2].plot(ns, [results[str(n)]["decision"]["cpu_s"] for n in ns], marker="o", label="CPU (one thread)")
    axes[2].set(xlabel="paddles N", ylabel="seconds", title="phyplan: first decision")
    axes[2].legend(fontsize=8)
    for ax in axes:
        ax.set_xticks(depths)
        ax.grid(alpha=0.3)
    fig.tight_layout()
    fig.savefig(path, dpi=110)


def print_tables(results: dict, task: str, varied: str, varied_contexts: int) -> None:
    """The figures of ``results`` (per N, per section) as markdown tables: regret on ``task`` and on ``varied``,
    the varied chain's accuracy on its first ``varied_contexts`` contexts, then the nominal chain's accuracy, cost
    and decision time."""
    depths = sorted(int(n) for n in results)
    for key, task in (("regret", task), ("regret-varied", varied)):
        agents = sorted({a for n in depths for a in results[str(n)].get(key, {})})
        if not agents:
            continue
        print(f"\n{task}, regret after 1 / 5 (/ last) attempts:")
        print("| agent | " + " | ".join(f"N={n}" for n in depths) + " |")
        print("|---|" + "---|" * len(depths))
        for a in agents:
            cells = []
            for n in depths:
                r = results[str(n)].get(key, {}).get(a)
                last = (f" / {r['regret_last']:.3f} ± {r['regret_last_hw']:.3f} (@{r['attempts']})"
                        if r is not None and r.get("attempts", 5) > 5 else "")
                cells.append("" if r is None else f"{r['regret1']:.3f} / {r['regret5']:.3f} ± {r['regret5_hw']:.3f}"
                             + last)
            print(f"| {a} | " + " | ".join(cells) + " |")
    for key, split in (("accuracy-varied", "test"), ("accuracy-varied-dev", "dev")):
        ns = [n for n in depths if key in results[str(n)]]
        if ns:
            print(f"\n{varied}, the conditioned chain's landing error on chain actions of {varied_contexts} {split} "
                  "contexts, mean / p90 (cm), no prediction:")
            print("| at | " + " | ".join(f"N={n}" for n in ns) + " |")
            print("|---|" + "---|" * len(ns))
            for at in ("true", "nominal", "guarded"):
                if any(at not in results[str(n)][key] for n in ns):
                    continue
                cells = [results[str(n)][key][at] for n in ns]
                label = "the true restitution, guard everywhere" if at == "guarded" else f"the {at} restitution"
                print(f"| {label} | " + " | ".join(
                    f"{100 * c['mean_m']:.1f} / {100 * c['p90_m']:.1f}, {100 * c['no_prediction']:.0f}%"
                    for c in cells) + " |")
    rows = [(n, results[str(n)]) for n in depths]
    print("\n| N | chain landing error mean / p90 (cm) | no prediction | chain / simulator per candidate | "
          "phyplan first decision, CPU s (wall s; candidates scored) |")
    print("|---|---|---|---|---|")
    for n, r in rows:
        a, c = r.get("accuracy"), r.get("cost")
        d = r.get("decision")
        decided = "" if d is None else f"{d['cpu_s']:.2f} ({d['wall_s']:.2f}" + (
            f"; {d['evaluations']:.0f})" if "evaluations" in d else ")")
        print(f"| {n} | " + (f"{100 * a['mean_m']:.1f} / {100 * a['p90_m']:.1f} | {100 * a['no_prediction']:.0f}%"
                             if a else " | ")
              + " | " + ("; ".join(f"{k}: {1e6 * v['chain_s']:.0f} us / {1e3 * v['sim_s']:.1f} ms ({v['ratio']:.0f}x)"
                                   for k, v in c.items()) if c else "")
              + f" | {decided} |")
