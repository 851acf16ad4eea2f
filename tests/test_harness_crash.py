"""The harness survives agents that end their process: an ``os._exit``, a SIGSEGV, a memory limit exceeded (a real
allocation, killed), a death in ``setup``, a call stuck in C while holding the interpreter, and an agent that kills
the harness's own process. The cell fails with the reason (shaped like a timed-out cell), the run goes on, and a
rerun of the same command adds nothing and terminates (benchmarks/harness/supervise.py, inflight.py). The agents are
in tests/reliability_agents.py.

Before this, each of these ended ``python -m benchmarks.run`` (code 7, -11, ...) and every rerun died on the same
cell again."""
from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

from benchmarks import harness
from benchmarks.harness import RunConfig

REPO = Path(__file__).resolve().parents[1]
AGENTS = "tests.reliability_agents:"
ENV = dict(os.environ, PYTHONPATH=str(REPO), MUJOCO_GL=os.environ.get("MUJOCO_GL", "egl"), OMP_NUM_THREADS="1")
MEMORY_LIMIT = "1000"
"""MB per worker for the memory test: a worker with the launch task and a simple agent holds about 350 MB; the
memory hog allocates 4096 MB more."""


@pytest.fixture(autouse=True)
def _repo_on_path(monkeypatch):
    monkeypatch.syspath_prepend(str(REPO))


def _bench(*args: str, timeout: float = 120, env: dict | None = None) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-m", "benchmarks.run", "--quiet", "--no-plots", *args], cwd=REPO,
                          env=env or ENV, capture_output=True, text=True, timeout=timeout)


def _lines(out: Path) -> list[dict]:
    return [json.loads(line) for line in (out / "attempts.jsonl").read_text().splitlines() if line.strip()]


CRASHES = {
    "exit": ("ExitCodeAgent", [], "crashed: exit code 7 during act()"),
    "sigsegv": ("SegfaultAgent", [], "crashed: signal 11 (SIGSEGV) during act()"),
    "memory": ("MemoryHogAgent", ["--memory-limit", MEMORY_LIMIT],
               f"crashed: out of memory: resident memory above --memory-limit {MEMORY_LIMIT} MB, killed (SIGKILL) "
               f"during act()"),
}


@pytest.mark.parametrize("workers", [1, 2], ids=["serial", "2-workers"])
@pytest.mark.parametrize("kind", list(CRASHES))
def test_an_agent_that_ends_its_process_fails_its_cells_and_the_run_goes_on(tmp_path, kind, workers):
    """The agent ends its process in act() of attempt 2 of every context: each such cell records attempt 1, the
    crash, and attempt 3 as not run; the next cell gets a fresh worker, the other agent runs, exit code 0; the
    summary quotes the crash; a rerun adds nothing."""
    cls, extra, reason = CRASHES[kind]
    out = tmp_path / "out"
    args = ["--tasks", "launch", "--agents", AGENTS + cls, "random", "--contexts", "2", "--attempts", "3",
            "--seeds", "1", "--workers", str(workers), "--out", str(out), *extra]
    first = _bench(*args)
    assert first.returncode == 0, first.stderr[-3000:]
    assert "Traceback" not in first.stderr
    recs = {(r["agent"], r["context"], r["attempt"]): r for r in _lines(out)}
    assert len(recs) == 2 * 2 * 3
    for (agent, _, attempt), r in recs.items():
        if agent == "random" or attempt == 1:
            assert r["error"] is None and r["reward"] is not None, r
        elif attempt == 2:
            assert r["error"] == reason and r["reward"] is None and r["action"] is None
            assert r["best"] == recs[(agent, r["context"], 1)]["best"]    # attempt 1's reward still counts
        else:
            assert r["error"] == f"not run: an earlier call crashed ({reason})"
    assert reason in (out / "summary.md").read_text()
    assert not (out / harness.INFLIGHT_NAME).exists() and not (out / "run.lock").exists()
    before = (out / "attempts.jsonl").read_bytes()
    again = _bench(*args)
    assert again.returncode == 0, again.stderr[-3000:]
    assert "4/4 cells done" in again.stderr
    assert (out / "attempts.jsonl").read_bytes() == before


def test_in_process_a_crash_ends_the_run_until_its_cell_is_recorded(tmp_path):
    """--in-process: the agent's os._exit ends the run (code 7). The rerun runs the in-flight cell again, alone, and
    dies again; the next one records it as crashed (the in-flight marker) and finishes the other cells."""
    out = tmp_path / "out"
    args = ["--tasks", "launch", "--agents", AGENTS + "ExitCodeAgent", "random", "--contexts", "1",
            "--attempts", "2", "--seeds", "1", "--in-process", "--out", str(out)]
    first = _bench(*args)
    assert first.returncode == 7
    marker = json.loads((out / harness.INFLIGHT_NAME).read_text())
    assert marker["running"] == [["launch", AGENTS + "ExitCodeAgent", 0, 200000]]
    second = _bench(*args)
    assert second.returncode == 7 and "each runs again alone first" in second.stderr
    third = _bench(*args)
    assert third.returncode == 0, third.stderr[-3000:]
    recs = {(r["agent"], r["attempt"]): r["error"] for r in _lines(out)}
    assert recs[(AGENTS + "ExitCodeAgent", 1)].startswith("crashed: the run itself died 2 times while this cell")
    assert recs[(AGENTS + "ExitCodeAgent", 2)].startswith("not run: an earlier call crashed")
    assert recs[("random", 1)] is None and recs[("random", 2)] is None
    assert not (out / harness.INFLIGHT_NAME).exists()
    fourth = _bench(*args)
    assert fourth.returncode == 0 and len(_lines(out)) == 4


def test_an_agent_that_kills_the_harness_is_recorded_on_the_third_run_and_others_are_not_blamed(tmp_path):
    """Two workers: the agent's seed-0 cell kills the main process while its seed-1 cell is running in the other
    worker. The rerun runs both suspects alone: the seed-0 cell kills it again; the third run records that cell as
    crashed and completes the seed-1 cell normally (it was running at the first death, but not at the second)."""
    out = tmp_path / "out"
    args = ["--tasks", "launch", "--agents", AGENTS + "ParentKillerAgent", "random", "--contexts", "1",
            "--attempts", "2", "--seeds", "2", "--workers", "2", "--out", str(out)]
    killer = AGENTS + "ParentKillerAgent"
    first = _bench(*args)
    assert first.returncode == -9
    running = json.loads((out / harness.INFLIGHT_NAME).read_text())["running"]
    assert sorted(running) == [["launch", killer, 0, 200000], ["launch", killer, 1, 200000]]
    assert _bench(*args).returncode == -9
    third = _bench(*args)
    assert third.returncode == 0, third.stderr[-3000:]
    recs = {(r["agent"], r["seed"], r["attempt"]): r for r in _lines(out)}
    assert len(recs) == 2 * 2 * 2
    assert recs[(killer, 0, 1)]["error"].startswith("crashed: the run itself died 2 times")
    assert all(r["error"] is None and r["reward"] is not None for k, r in recs.items() if k[:2] != (killer, 0))
    assert _bench(*args).returncode == 0 and len(_lines(out)) == 8


def test_a_crash_in_setup_makes_the_agent_unavailable_as_a_failing_setup_does(tmp_path):
    """A set-up that ends its process is reported, not recorded, as a set-up that raises (exit code 1 without
    --skip-missing; the rerun tries it again), and tried once per set-up, not in a new worker for each cell."""
    out, exits = tmp_path / "out", tmp_path / "setup-exits.txt"
    args = ["--tasks", "launch", "--agents", AGENTS + "SetupExitAgent", "random", "--contexts", "3", "--attempts", "2",
            "--seeds", "1", "--out", str(out)]
    for run in (1, 2):
        res = _bench(*args, env=dict(ENV, SETUP_EXITS=str(exits)))
        assert res.returncode == 1, res.stderr[-3000:]
        assert (f"error: agent '{AGENTS}SetupExitAgent' could not be set up on launch (seeds [0]): setup: crashed: "
                f"exit code 3; its cells were not run") in res.stderr
        assert exits.read_text().split() == ["0"] * run
        recs = _lines(out)
        assert {r["agent"] for r in recs} == {"random"} and len(recs) == 3 * 2
        assert all(r["error"] is None for r in recs)


def test_a_call_stuck_in_c_holding_the_interpreter_is_killed_by_the_main_process(tmp_path):
    """Neither the alarm nor the watchdog thread can run in a process whose agent holds the interpreter lock in C:
    the main process kills the worker 2 x grace after the time limit, the attempt fails with the timeout, and the
    run goes on. (Before, the run hung for good.)"""
    out = tmp_path / "out"
    stuck = AGENTS + "GilStuckAgent"
    args = ["--tasks", "launch", "--agents", stuck, "random", "--contexts", "1", "--attempts", "2", "--seeds", "1",
            "--attempt-timeout", "1", "--out", str(out)]
    res = _bench(*args, env=dict(ENV, PHYPLAN_TIMEOUT_GRACE="1"), timeout=60)
    assert res.returncode == 0, res.stderr[-3000:]
    errors = {(r["agent"], r["attempt"]): r["error"] for r in _lines(out)}
    assert errors[(stuck, 1)] == ("timeout: act() did not return within 1 s (--attempt-timeout); the agent did not "
                                  "stop (stuck outside Python, holding the interpreter), so its worker process was "
                                  "killed")
    assert errors[(stuck, 2)].startswith("not run: an earlier call timed out (timeout: act() did not return")
    assert errors[("random", 1)] is None and errors[("random", 2)] is None


@pytest.mark.slow
def test_on_ray_a_dead_worker_fails_its_cell_and_the_run_finishes(tmp_path):
    """Ray runs each cell as a task and returns its records when it ends: a worker that dies loses the cell's
    records, so after Ray's one retry the whole cell is recorded as crashed (attempt 1 with Ray's reason, the later
    ones not run). Before, Ray's error ended the run, and every rerun again."""
    pytest.importorskip("ray", reason="Ray is an optional extra (pip install 'phyplan[ray]'); backend not tested")
    crasher = AGENTS + "ExitCodeAgent"
    cfg = RunConfig(tasks=["launch"], agents=[crasher, "random"], contexts=2, attempts=3, seeds=1)
    res = harness.run(cfg, tmp_path / "out", workers=2, backend="ray", progress=False, log=lambda m: None)
    errors = {(r.agent, r.context, r.attempt): r.error for r in res.records}
    assert len(errors) == 2 * 2 * 3
    for (agent, _, attempt), error in errors.items():
        if agent == "random":
            assert error is None
        elif attempt == 1:
            assert error.startswith("crashed: the Ray worker running the cell died (WorkerCrashedError: "), error
        else:
            assert error.startswith("not run: an earlier call crashed (crashed: the Ray worker")
    again = harness.run(cfg, tmp_path / "out", workers=2, backend="ray", progress=False, log=lambda m: None)
    assert again.ran == 0 and len(again.records) == 12


def test_bad_isolation_options_are_clear_errors(tmp_path):
    cfg = RunConfig(tasks=["launch"], agents=["random"], contexts=1, attempts=1, seeds=1)
    for kw, msg in ((dict(isolate=False, workers=2), "needs workers=1"),
                    (dict(memory_limit=0), "positive number of megabytes"),
                    (dict(memory_limit="1 GB"), "positive number of megabytes"),
                    (dict(memory_limit=500, isolate=False), "needs the agents in the harness's worker processes"),
                    (dict(isolate="yes"), "isolate must be True or False")):
        with pytest.raises(ValueError, match=msg):
            harness.run(cfg, tmp_path / "out", progress=False, log=lambda m: None, **kw)
    with pytest.raises(ValueError, match="must be picklable"):
        harness.run(cfg, tmp_path / "out", progress=False, log=lambda m: None, agent_specs={"random": lambda: 0})
    base = ["--tasks", "launch", "--agents", "random", "--contexts", "1", "--attempts", "1", "--seeds", "1",
            "--out", str(tmp_path / "cli")]
    for extra, msg in ((["--memory-limit", "-5"], "--memory-limit must be a positive number"),
                       (["--in-process", "--workers", "2"], "--in-process runs the agents in this process"),
                       (["--in-process", "--memory-limit", "800"], "--memory-limit needs the agents")):
        res = _bench(*base, *extra)
        assert res.returncode == 2 and msg in res.stderr and "Traceback" not in res.stderr, res.stderr
