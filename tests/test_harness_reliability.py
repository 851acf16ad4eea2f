"""The harness: one writer per results directory, a time limit per agent call, every agent exception
recorded (BaseException too) while a user's Ctrl-C stops cleanly, damaged records named and repaired, and clear
errors for an unusable --out. The misbehaving agents are in tests/reliability_agents.py."""
from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

from benchmarks import harness, report, run
from benchmarks.harness import RunConfig
from benchmarks.harness.guard import STUCK_EXIT, Guard

REPO = Path(__file__).resolve().parents[1]
HANG = "tests.reliability_agents:HangingAgent"
EXIT = "tests.reliability_agents:ExitingAgent"
SLOW = "tests.reliability_agents:SlowAgent"
ENV = dict(os.environ, PYTHONPATH=str(REPO), MUJOCO_GL=os.environ.get("MUJOCO_GL", "egl"), OMP_NUM_THREADS="1")


@pytest.fixture(autouse=True)
def _repo_on_path(monkeypatch):
    monkeypatch.syspath_prepend(str(REPO))


def _bench(*args: str, timeout: float = 300, **popen) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-m", "benchmarks.run", "--quiet", "--no-plots", *args], cwd=REPO,
                          env=popen.pop("env", ENV), capture_output=True, text=True, timeout=timeout, **popen)


def _lines(out: Path) -> list[dict]:
    return [json.loads(line) for line in (out / "attempts.jsonl").read_text().splitlines() if line.strip()]


# ======================================================================================================== the lock
def test_a_second_run_on_a_locked_directory_is_refused(tmp_path):
    """Before: a second process's resume replaced attempts.jsonl under the first one, which kept appending to the
    deleted file (48 of 90 records lost). Now the second run is refused while the first is alive."""
    out = tmp_path / "out"
    args = ["--tasks", "launch", "--agents", SLOW, "--contexts", "3", "--attempts", "2", "--seeds", "1",
            "--out", str(out)]
    first = subprocess.Popen([sys.executable, "-m", "benchmarks.run", "--quiet", "--no-plots", *args], cwd=REPO,
                             env=ENV, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    try:
        deadline = time.time() + 120
        while not (out / "run.lock").exists() or not (out / "run.lock").read_text().strip():
            assert time.time() < deadline and first.poll() is None, first.stderr.read() if first.poll() else ""
            time.sleep(0.1)
        second = _bench(*args)
        assert second.returncode == 1
        assert f"is in use by another benchmark run (pid {first.pid} on host" in second.stderr
        assert first.wait(timeout=240) == 0
    finally:
        if first.poll() is None:
            first.kill()
    assert len(_lines(out)) == 6 and not (out / "run.lock").exists()


def test_a_stale_lock_of_a_dead_process_is_taken_over(tmp_path):
    out = tmp_path / "out"
    holder = subprocess.Popen([sys.executable, "-c", "import sys, time; from benchmarks.harness import DirLock; "
                               "DirLock(sys.argv[1]).acquire(); print('locked', flush=True); time.sleep(600)",
                               str(out)], cwd=REPO, env=ENV, stdout=subprocess.PIPE, text=True)
    out.mkdir()
    assert holder.stdout.readline().strip() == "locked"
    with pytest.raises(harness.DirLocked, match=f"pid {holder.pid}"):
        harness.DirLock(out).acquire()
    holder.kill()                                  # kill -9: the lock file stays, its flock is gone
    holder.wait()
    assert json.loads((out / "run.lock").read_text())["pid"] == holder.pid
    with harness.DirLock(out) as lock:
        assert json.loads(lock.path.read_text())["pid"] == os.getpid()
    assert not (out / "run.lock").exists()


# ================================================================================================= time limits
@pytest.mark.parametrize("workers, isolate", [(1, True), (1, False), (2, True)],
                         ids=["serial", "in-process", "2-workers"])
def test_a_hanging_agent_fails_its_attempt_and_the_run_goes_on(tmp_path, monkeypatch, workers, isolate):
    """Before: an act() that never returned hung the run forever. Now (limit 1 s) the attempt fails with the reason,
    the cell's later attempts are recorded as not run, the next cell gets a fresh agent, and the run finishes."""
    cfg = RunConfig(tasks=["launch"], agents=[HANG, "random"], contexts=2, attempts=3, seeds=2)
    setups = tmp_path / "setups.txt"
    monkeypatch.setenv("HANG_SETUPS", str(setups))      # the agent's set-ups, in whichever process they happen
    t0 = time.time()
    res = harness.run(cfg, tmp_path / "out", workers=workers, progress=False, log=lambda m: None,
                      attempt_timeout=1.0, agent_specs={HANG: HANG}, isolate=isolate)
    assert time.time() - t0 < 120
    recs = {(r.agent, r.seed, r.context, r.attempt): r for r in res.records}
    assert len(recs) == 2 * 2 * 2 * 3
    hung = [r for r in res.records if r.agent == HANG and r.seed == 0]
    for r in hung:
        if r.attempt == 1:
            assert r.error is None and r.reward is not None
        elif r.attempt == 2:
            assert r.error == "timeout: act() did not return within 1 s (--attempt-timeout)"
            assert 0.9 < r.act_time < 5
        else:
            assert r.error.startswith("not run: an earlier call timed out")
    assert all(r.error is None for r in res.records if r.agent == "random" or r.seed == 1)
    if workers == 1:        # one process runs every cell: a fresh agent for each cell after a timeout
        assert setups.read_text().split() == ["0", "0", "1"]


def test_a_python_loop_that_catches_exception_is_stopped_too(tmp_path):
    spin = "tests.reliability_agents:SpinningAgent"
    cfg = RunConfig(tasks=["launch"], agents=[spin], contexts=1, attempts=2, seeds=1)
    t0 = time.time()
    res = harness.run(cfg, tmp_path / "out", progress=False, log=lambda m: None, attempt_timeout=0.5,
                      agent_specs={spin: spin})
    assert time.time() - t0 < 60
    assert [r.error.split(":")[0] for r in res.records] == ["timeout", "not run"]
    guard = Guard(0.2)
    assert guard.call("act", lambda: 7) == (7, None)           # a call within the limit returns its value
    assert guard.call("act", lambda: 1 / 0)[1].__class__ is ZeroDivisionError


@pytest.mark.parametrize("in_process", [True, False], ids=["in-process", "worker"])
def test_the_backstop_ends_a_process_stuck_outside_python_after_recording_the_cell(tmp_path, in_process):
    """An agent that never returns to Python (here: SIGALRM blocked while it sleeps) cannot be interrupted: after
    the grace period the process records the cell's attempts as failed and exits (code 75). In this process
    (--in-process) that ends the run and the rerun resumes; in a worker process only the worker ends and the run
    goes on with the next cell."""
    out = tmp_path / "out"
    env = dict(ENV, PHYPLAN_TIMEOUT_GRACE="1", STUCK_MARKER=str(tmp_path / "stuck-once"))
    args = ["--tasks", "launch", "--agents", "tests.reliability_agents:StuckAgent", "--contexts", "2",
            "--attempts", "2", "--seeds", "1", "--attempt-timeout", "1", "--out", str(out)]
    args += ["--in-process"] if in_process else []
    first = _bench(*args, env=env)
    assert first.returncode == (STUCK_EXIT if in_process else 0), first.stderr
    recs = _lines(out)
    assert [r["attempt"] for r in recs] == ([1, 2] if in_process else [1, 2, 1, 2])
    assert all("did not stop (stuck outside Python)" in r["error"] for r in recs[:2])
    assert in_process or all(r["error"] is None for r in recs[2:])
    second = _bench(*args, env=env)
    assert second.returncode == 0, second.stderr
    assert len(_lines(out)) == 4


def test_base_exceptions_of_an_agent_are_recorded(tmp_path):
    """Before: SystemExit/KeyboardInterrupt from an agent ended the run with no record."""
    cfg = RunConfig(tasks=["launch"], agents=[EXIT], contexts=1, attempts=4, seeds=1)
    res = harness.run(cfg, tmp_path / "out", progress=False, log=lambda m: None, agent_specs={EXIT: EXIT})
    errors = [r.error for r in sorted(res.records, key=lambda r: r.attempt)]
    assert errors[0].startswith("act: SystemExit: 3")
    assert errors[1].startswith("act: KeyboardInterrupt: raised by the agent")
    assert errors[2].startswith("observe: GeneratorExit")
    assert errors[3] is None
    assert res.records[2].reward is not None         # observe failed after the attempt ran: its reward counts


def test_ctrl_c_stops_the_run_and_keeps_every_finished_record(tmp_path):
    out = tmp_path / "out"
    args = ["--tasks", "launch", "--agents", SLOW, "--contexts", "6", "--attempts", "2", "--seeds", "1",
            "--out", str(out)]
    proc = subprocess.Popen([sys.executable, "-m", "benchmarks.run", "--quiet", "--no-plots", *args], cwd=REPO,
                            env=ENV, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    try:
        deadline = time.time() + 120
        while not (out / "attempts.jsonl").exists() or len(_lines(out)) < 3:
            assert time.time() < deadline and proc.poll() is None
            time.sleep(0.05)
        proc.send_signal(signal.SIGINT)
        code = proc.wait(timeout=60)
    finally:
        if proc.poll() is None:
            proc.kill()
    assert code != 0
    kept = _lines(out)
    assert 3 <= len(kept) < 12 and not (out / "run.lock").exists()
    done = _bench(*args)
    assert done.returncode == 0, done.stderr
    final = _lines(out)
    assert len(final) == 12
    assert {(r["context"], r["attempt"]): r["reward"] for r in kept if r["attempt"] == 2} .items() <= \
        {(r["context"], r["attempt"]): r["reward"] for r in final}.items()


# ============================================================================================== damaged records
@pytest.fixture(scope="module")
def finished_dir(tmp_path_factory):
    out = tmp_path_factory.mktemp("bench") / "out"
    done = _bench("--tasks", "launch", "--agents", "random", "--contexts", "3", "--attempts", "2", "--seeds", "1",
                  "--out", str(out))
    assert done.returncode == 0, done.stderr
    return out


def _damaged_copy(src: Path, dst: Path, line: int, new: bytes) -> Path:
    dst.mkdir()
    (dst / "config.json").write_bytes((src / "config.json").read_bytes())
    lines = (src / "attempts.jsonl").read_bytes().split(b"\n")
    lines[line - 1] = new
    (dst / "attempts.jsonl").write_bytes(b"\n".join(lines))
    return dst


def _edit(line: bytes, **kw) -> bytes:
    d = json.loads(line)
    d.update(kw)
    return json.dumps(d).encode()


DAMAGE = {
    "invalid JSON": (lambda line: line[:40], "not valid JSON"),
    "non-UTF-8 bytes": (lambda line: line[:20] + b"\xff\xfe" + line[22:], "not UTF-8 text"),
    "wrong-typed field": (lambda line: _edit(line, reward="high"), "field 'reward' must be number or none"),
    "out-of-range attempt": (lambda line: _edit(line, attempt=9), r"attempt 9 is out of range: this run has "
                                                                   r"attempts 1..2"),
}


@pytest.mark.parametrize("kind", list(DAMAGE))
def test_damaged_records_are_named_then_repaired(finished_dir, tmp_path, kind):
    """Before: raw tracebacks in benchmarks.run and the report, and an out-of-range attempt dropped silently."""
    damage, reason = DAMAGE[kind]
    original = (finished_dir / "attempts.jsonl").read_bytes().split(b"\n")
    out = _damaged_copy(finished_dir, tmp_path / "out", 3, damage(original[2]))
    args = ["--tasks", "launch", "--agents", "random", "--contexts", "3", "--attempts", "2", "--seeds", "1",
            "--out", str(out)]
    res = _bench(*args)
    assert res.returncode == 1 and "Traceback" not in res.stderr
    assert "attempts.jsonl is damaged: line 3: " in res.stderr and "--repair" in res.stderr
    assert __import__("re").search(reason, res.stderr), res.stderr
    rep = subprocess.run([sys.executable, "-m", "benchmarks.report", str(out), "--no-plots"], cwd=REPO, env=ENV,
                         capture_output=True, text=True, timeout=120)
    assert rep.returncode == 1 and "Traceback" not in rep.stderr and "line 3: " in rep.stderr
    fixed = _bench(*args, "--repair")
    assert fixed.returncode == 0, fixed.stderr
    assert (out / harness.REJECTED_NAME).read_bytes() == damage(original[2]) + b"\n"
    key = ("task", "agent", "seed", "context", "attempt")

    def outcome(lines):
        return {tuple(r[k] for k in key): (r["action"], r["reward"], r["error"]) for r in lines}
    assert outcome(_lines(out)) == outcome(_lines(finished_dir))       # the damaged cell ran again, identically
    assert _bench(*args).returncode == 0                              # and the directory is clean now


def test_out_pointing_at_a_file_or_an_impossible_path_is_a_clear_error(tmp_path):
    a_file = tmp_path / "results.txt"
    a_file.write_text("not a directory")
    for out, msg in ((a_file, "is a file, not a directory"), (a_file / "sub", "cannot create the directory"),
                     (Path("/proc/phyplan-results"), "cannot create the directory")):
        res = _bench("--tasks", "launch", "--agents", "random", "--contexts", "1", "--attempts", "1",
                     "--seeds", "1", "--out", str(out), timeout=120)
        assert res.returncode == 2 and "Traceback" not in res.stderr and msg in res.stderr, res.stderr
    with pytest.raises(harness.OutDirError, match="is a file"):
        harness.check_out_dir(a_file)


def test_records_with_wrong_types_are_refused_field_by_field():
    good = json.loads(harness.AttemptRecord(
        task="launch", agent="a", seed=0, context=1, split="test", attempt=1, action=[0.1, 0.2], reward=0.5,
        best=0.5, regret=0.5, success=False, solved=False, distance=0.3, begin_time=0.0, act_time=0.0,
        step_time=0.0, observe_time=0.0, sim_calls=0, skill_evals=0.0).to_json())
    harness.AttemptRecord.from_dict(good)
    for field, value in (("seed", "0"), ("attempt", True), ("action", [0.1, "x"]), ("success", 1), ("attempt", 0),
                         ("agent_stats", {"a": "b"}), ("reward", float("nan"))):
        with pytest.raises(TypeError, match=f"'{field}'"):
            harness.AttemptRecord.from_dict({**good, field: value})
    assert callable(report.main) and callable(run.main)


def test_a_real_sigint_is_not_taken_for_an_agent_error_and_the_handler_is_restored():
    from benchmarks.harness.guard import interrupts_marked
    before = signal.getsignal(signal.SIGINT)
    guard = Guard(5.0)

    def agent_raises():
        raise KeyboardInterrupt("mine")

    def user_presses_ctrl_c():
        os.kill(os.getpid(), signal.SIGINT)
        time.sleep(5)

    with interrupts_marked():
        assert isinstance(guard.call("act", agent_raises)[1], KeyboardInterrupt)      # recorded
        with pytest.raises(KeyboardInterrupt):
            guard.call("act", user_presses_ctrl_c)                                    # stops
    assert signal.getsignal(signal.SIGINT) is before


def test_the_harness_refuses_non_real_actions_as_the_env_does():
    import numpy as np

    from benchmarks.harness import validate_action
    low, high = np.zeros(2), np.ones(2)
    for bad in (["0.5", "0.5"], np.array([0.5 + 1j, 0.5]), [True, False], "0.5"):
        a, reason = validate_action(bad, low, high, ("x", "y"))
        assert a is None and reason.startswith("action is not numeric"), (bad, reason)
    a, reason = validate_action(np.array([0.5, 1.0], dtype=np.float32), low, high, ("x", "y"))
    assert reason is None and a.dtype == np.float64 and a.tolist() == [0.5, 1.0]
    a, _ = validate_action(np.array([0.25, 0.5], dtype=object), low, high, ("x", "y"))
    assert a.tolist() == [0.25, 0.5]
