"""Benchmarks: the harness that scores any agent on any task (``python -m benchmarks.run``) and speed studies.

* :mod:`benchmarks.run` — the command line (``phyplan-bench``).
* :mod:`benchmarks.harness` — the protocol loop, attempt records, resume, parallel workers and Ray.
* :mod:`benchmarks.report` — summaries (regret with 95% CIs, AUC, success, runtime), tables and plots.
* :mod:`benchmarks.splits` — the fixed train / dev / test context seeds.
* :mod:`benchmarks.paper_reference` — the PhyPlan paper's logged regrets, shown beside ours.
"""
