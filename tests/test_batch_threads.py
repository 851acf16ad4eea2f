"""simulate_batch and what is built on it (Simulator.evaluate_batch, the vector env) from several threads at once,
from a forked child, re-entered, and interrupted by SIGINT: serial results bit for bit, or a clear error, and no
worker left behind."""
from __future__ import annotations

import multiprocessing as mp
import os
import signal
import subprocess
import sys
import textwrap
import threading
import time
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

import gymnasium as gym
import numpy as np
import pytest

import phyplan_envs  # noqa: F401 - registers the ids
from phyplan_agents.base import Simulator
from phyplan_envs import batch, batch_pool, simulate_batch
from phyplan_envs.vector import PhyPlanVectorEnv

ENV_ID = "PhyPlan/Launch-v0"       # the cheapest task (about 2 ms an episode)
ROOT = Path(__file__).resolve().parent.parent


def _contexts_and_actions(seed: int, n_ctx: int, n: int):
    env = gym.make(ENV_ID)
    u = env.unwrapped
    contexts = [env.reset(seed=seed + k)[1]["context"] for k in range(n_ctx)]
    rng = np.random.default_rng(seed)
    return contexts, [u._low64 + (u._high64 - u._low64) * rng.random((n, len(u._low64))) for _ in range(n_ctx)]


def _rows(res) -> list[np.ndarray]:
    return [res.reward, res.final_pos, np.stack(res.obs)]


def _same(a: list[np.ndarray], b: list[np.ndarray]) -> bool:
    return len(a) == len(b) and all(x.shape == y.shape and np.array_equal(x, y) for x, y in zip(a, b))


def _thread_tasks(rounds: int, n: int) -> tuple[dict, Simulator]:
    """Named callables, each a few rounds of batches on its own contexts and actions, returning every result."""
    contexts, actions = _contexts_and_actions(seed=40, n_ctx=rounds * 4, n=n)
    shared = Simulator(gym.make(ENV_ID), contexts[0], workers=1)      # one Simulator (one env) for two threads

    def batches(k: int, workers: int):
        def run():
            out = []
            for r in range(rounds):
                i = (k * rounds + r) % len(contexts)
                out += _rows(simulate_batch(ENV_ID, contexts[i], actions[i], workers=workers))
            return out
        return run

    def simulator(k: int):
        def run():
            return [shared.evaluate_batch(actions[(k * rounds + r) % len(contexts)])[0] for r in range(rounds)]
        return run

    def vector():
        vec = PhyPlanVectorEnv(ENV_ID, num_envs=n, workers=2, autoreset_mode="same_step")
        vec.reset(seed=7)
        out = [vec.step(actions[r])[1] for r in range(rounds)]       # a new context per sub-env every step
        vec.close()
        return out

    return {"w2 a": batches(0, 2), "w2 b": batches(1, 2), "w1 a": batches(2, 1), "w1 b": batches(3, 1),
            "sim a": simulator(0), "sim b": simulator(1), "vector": vector}, shared


def test_threads_get_the_serial_results_bit_for_bit():
    """Seven threads at once (two on the 2-worker pool, two in-process, two on one Simulator, a vector env on the
    pool), three times over: every result equals the serial one."""
    rounds, n = 4, 12
    tasks, shared = _thread_tasks(rounds, n)
    serial = {name: task() for name, task in tasks.items()}
    start = threading.Barrier(len(tasks))

    def together(task):
        start.wait(timeout=60)
        return task()

    for attempt in range(3):
        calls = shared.calls
        with ThreadPoolExecutor(max_workers=len(tasks)) as ex:
            futures = {name: ex.submit(together, task) for name, task in tasks.items()}
            got = {name: f.result(timeout=120) for name, f in futures.items()}
        wrong = [name for name in tasks if not _same(got[name], serial[name])]
        assert not wrong, f"attempt {attempt}: results differ from serial in threads {wrong}"
        assert shared.calls - calls == 2 * rounds * n


def test_close_pools_from_another_thread_lets_a_running_batch_finish():
    contexts, actions = _contexts_and_actions(seed=60, n_ctx=1, n=150)
    ref = _rows(simulate_batch(ENV_ID, contexts[0], actions[0], workers=1))
    simulate_batch(ENV_ID, contexts[0], actions[0][:4], workers=2)                     # a started pool
    with ThreadPoolExecutor(max_workers=1) as ex:
        running = ex.submit(simulate_batch, ENV_ID, contexts[0], actions[0], workers=2)
        time.sleep(0.1)
        batch.close_pools()                     # waits for the running batch, then shuts its workers down
        assert _same(_rows(running.result(timeout=120)), ref)
    assert not batch_pool._POOLS
    assert _same(_rows(simulate_batch(ENV_ID, contexts[0], actions[0], workers=2)), ref)  # a new pool


def test_a_call_inside_a_running_call_is_a_clear_error(monkeypatch):
    """Re-entering simulate_batch from the thread that runs a batch (here from inside the reply loop, as a signal
    handler could) raises instead of mixing the two batches' jobs on one pool; the pool is then replaced."""
    contexts, actions = _contexts_and_actions(seed=70, n_ctx=2, n=16)
    ref = _rows(simulate_batch(ENV_ID, contexts[0], actions[0], workers=1))
    simulate_batch(ENV_ID, contexts[0], actions[0][:4], workers=2)
    recv = batch_pool._recv
    inner = []

    def recv_and_reenter(fh):
        if not inner:
            inner.append(1)
            simulate_batch(ENV_ID, contexts[1], actions[1], workers=2)
        return recv(fh)

    monkeypatch.setattr(batch_pool, "_recv", recv_and_reenter)
    with pytest.raises(RuntimeError, match="called again from the thread that is running a batch"):
        simulate_batch(ENV_ID, contexts[0], actions[0], workers=2)
    monkeypatch.setattr(batch_pool, "_recv", recv)
    assert _same(_rows(simulate_batch(ENV_ID, contexts[0], actions[0], workers=2)), ref)


def _forked_child(contexts, actions, queue) -> None:
    try:
        queue.put([simulate_batch(ENV_ID, c, a, workers=2).reward for c, a in zip(contexts, actions)])
    except BaseException as exc:  # noqa: BLE001 - reported to the parent
        queue.put(repr(exc))
    finally:
        batch.close_pools()


@pytest.mark.skipif(not hasattr(os, "fork"), reason="needs fork")
def test_a_child_forked_while_another_thread_holds_the_pools_starts_its_own():
    """Forked while another thread holds the registry of pools (as while it starts one): the child, which has
    only the forking thread, must not wait for that lock, nor talk to its parent's workers; both get serial
    results."""
    contexts, actions = _contexts_and_actions(seed=80, n_ctx=3, n=24)
    ref = [simulate_batch(ENV_ID, c, a, workers=1).reward for c, a in zip(contexts, actions)]
    simulate_batch(ENV_ID, contexts[0], actions[0][:4], workers=2)           # the parent's pool is up
    held, release = threading.Event(), threading.Event()

    def hold():
        with batch_pool._POOLS_LOCK:
            held.set()
            release.wait(timeout=60)

    holder = threading.Thread(target=hold)
    holder.start()
    assert held.wait(timeout=10)
    ctx = mp.get_context("fork")
    queue = ctx.Queue()
    child = ctx.Process(target=_forked_child, args=(contexts, actions, queue))
    try:
        child.start()
        release.set()
        holder.join()
        mine = [simulate_batch(ENV_ID, c, a, workers=2).reward for c, a in zip(contexts, actions)]
        theirs = queue.get(timeout=30)
    finally:
        release.set()
        child.join(timeout=30)
        if child.is_alive():
            child.kill()
    assert not isinstance(theirs, str), theirs
    assert all(np.array_equal(t, r) for t, r in zip(theirs, ref)) and len(theirs) == len(ref)
    assert all(np.array_equal(m, r) for m, r in zip(mine, ref))
    assert child.exitcode == 0


_SIGINT_CHILD = textwrap.dedent("""
    import faulthandler, os, signal, sys, numpy as np, gymnasium as gym
    faulthandler.register(signal.SIGUSR1, all_threads=True)      # the test asks for the stacks if it hangs
    signal.signal(signal.SIGINT, signal.default_int_handler)     # as in a terminal, also when pytest was started in
                                                                 # the background (a shell's `&` ignores SIGINT)
    import phyplan_envs
    from phyplan_envs import simulate_batch
    from phyplan_envs.batch import worker_pool
    env = gym.make("PhyPlan/Launch-v0")
    ctx = env.reset(seed=1)[1]["context"]
    u = env.unwrapped
    acts = u._low64 + (u._high64 - u._low64) * np.random.default_rng(0).random((2000, 2))
    simulate_batch("PhyPlan/Launch-v0", ctx, acts[:4], workers=2)
    workers = [w.proc for w in worker_pool(2).workers]
    print("WORKERS", *[p.pid for p in workers], flush=True)
    try:
        while True:          # chunks of 250 episodes: each reply is larger than a pipe's buffer
            simulate_batch("PhyPlan/Launch-v0", ctx, acts, workers=2)
    except KeyboardInterrupt:
        print("INTERRUPTED", *[p.returncode for p in workers], flush=True)
        sys.exit(42)
""")


def _gone(pid: int) -> bool:
    try:
        with open(f"/proc/{pid}/stat") as f:
            return f.read().rsplit(")", 1)[1].split()[0] == "Z"        # a zombie has ended
    except FileNotFoundError:
        return True


@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="reads /proc")
def test_sigint_to_the_caller_ends_the_batch_at_once_and_leaves_no_worker():
    """``kill -INT`` to the calling process only (not its group) during a batch: KeyboardInterrupt in the caller
    within a few seconds, its workers killed and reaped before it propagates, none left running."""
    proc = subprocess.Popen([sys.executable, "-c", _SIGINT_CHILD], cwd=ROOT, stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, text=True, start_new_session=True)   # a group to clean up
    pids: list[int] = []
    try:
        line = proc.stdout.readline()
        assert line.startswith("WORKERS"), line + proc.stderr.read()
        pids = [int(x) for x in line.split()[1:]]
        assert len(pids) == 2 and not any(_gone(p) for p in pids)
        time.sleep(0.5)                         # well inside a batch
        sent = time.monotonic()
        os.kill(proc.pid, signal.SIGINT)
        try:
            out, err = proc.communicate(timeout=15)      # generous for a loaded machine; `took` is checked below
        except subprocess.TimeoutExpired:
            os.kill(proc.pid, signal.SIGUSR1)            # its threads' stacks, then the failure shows where it hung
            time.sleep(1.0)
            proc.kill()
            _, err = proc.communicate()
            pytest.fail(f"the caller did not end within 15 s of SIGINT (workers {pids}); its stacks:\n{err[-6000:]}")
        took = time.monotonic() - sent
        assert proc.returncode == 42, err
        assert out.split()[0] == "INTERRUPTED" and all(int(rc) == -signal.SIGKILL for rc in out.split()[1:]), out
        assert took < 4.0, took
        deadline = time.monotonic() + 2.0
        while not all(_gone(p) for p in pids) and time.monotonic() < deadline:
            time.sleep(0.05)
        assert all(_gone(p) for p in pids), [p for p in pids if not _gone(p)]
    finally:
        if proc.poll() is None:
            proc.kill()
        try:
            os.killpg(proc.pid, signal.SIGKILL)       # the workers too, if any is left (they share its group)
        except (ProcessLookupError, PermissionError):
            pass
        proc.wait()
