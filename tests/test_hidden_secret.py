"""The varied track's sealed physics: what the harness hands an agent (context, observation, info, simulator, task
info) gives no way to the hidden values through the package's public functions, while envs holding the process's
secret (this process, simulate_batch workers, child processes that inherit PHYPLAN_PHYSICS_SECRET) replay every
context bit for bit, and envs holding another secret reject its contexts."""
from __future__ import annotations

import importlib
import json
import os
import pickle
import re
import subprocess
import sys
from pathlib import Path

import gymnasium as gym
import numpy as np
import pytest

import phyplan_envs
from phyplan_agents import Simulator, TaskInfo
from phyplan_envs import hidden_physics as hp
from phyplan_envs import simulate_batch
from phyplan_envs.spaces import SECRET_ENV, TOKEN_PREFIX, _process_secret, seal, secret_bytes, unseal
from phyplan_envs.splits import SPLITS

ROOT = Path(__file__).resolve().parent.parent
IDS = [phyplan_envs.env_id(t) for t in phyplan_envs.VARIED_TASKS] + ["PhyPlan/SlideVaried-v0",
                                                                      "PhyPlan/BridgeVaried-v0"]
SEEDS = (4, SPLITS["dev"][2], SPLITS["test"][0], SPLITS["test"][9])


def _make(env_id: str, **kw):
    return gym.make(env_id, with_panda=False, **kw)


def _base(env_id: str) -> str:
    """The base task of a varied id (``"PhyPlan/LaunchBounceVaried-v0"`` -> ``"launch-bounce"``)."""
    module, _, attr = str(gym.spec(env_id).entry_point).partition(":")
    return getattr(importlib.import_module(module), attr).base_task


def _leaves(x):
    if isinstance(x, dict):
        for k, v in x.items():
            yield k
            yield from _leaves(v)
    elif isinstance(x, (list, tuple)):
        for v in x:
            yield from _leaves(v)
    elif isinstance(x, np.ndarray):
        yield from x.ravel().tolist()
    else:
        yield x


def _candidates(held) -> set[int]:
    """Every integer an agent could take for a physics key from what it holds: integer leaves, and each hex string
    (the token) as one number and as every 8-byte window of its bytes."""
    out: set[int] = set()
    for v in _leaves(held):
        if isinstance(v, (int, np.integer)) and not isinstance(v, bool):
            out.add(int(v) % hp.KEY_BOUND)
        elif isinstance(v, str):
            digits = re.sub(r"[^0-9a-f]", "", v.lower().removeprefix(TOKEN_PREFIX))
            if digits:
                out.add(int(digits, 16) % hp.KEY_BOUND)
                raw = bytes.fromhex(digits[:len(digits) // 2 * 2])
                out.update(int.from_bytes(raw[i:i + 8], "big") % hp.KEY_BOUND for i in range(max(1, len(raw) - 7)))
    return out


def _leak(task: str, held, hidden: dict, key: int) -> str | None:
    """How ``held`` gives the hidden values away through the public functions, or None."""
    for v in _leaves(held):
        if v is not None and not isinstance(v, float) and str(v) in (str(key), format(key, "x"), format(key, "X")):
            return f"the raw key {key} itself"
        if isinstance(v, str) and (str(key) in v or format(key, "016x") in v.lower()):
            return f"the raw key {key} inside {v!r}"
    for x in _candidates(held):
        for space in hp.SPACES:
            if hp.values_of_key(task, x, space) == hidden:
                return f"values_of_key({task!r}, {x}, {space!r})"
    return None


@pytest.mark.parametrize("env_id", IDS)
def test_what_the_agent_holds_gives_no_way_to_the_values(env_id):
    task = _base(env_id)
    env, sim_env = _make(env_id), _make(env_id)
    env.action_space.seed(0)
    secret_text = os.environ[SECRET_ENV]
    for seed in SEEDS:
        obs, info = env.reset(seed=seed)
        ctx, hidden = info["context"], env.unwrapped.hidden_physics
        assert set(ctx) == {"goal", "physics_token"}
        key, space = hp.open_token(task, ctx["physics_token"], _process_secret())
        assert hp.values_of_key(task, key, space) == hidden                # the seal holds what the env uses
        # the detector finds the leak of the old format (the raw key in the context)
        assert _leak(task, {**ctx, "physics_key": key, "physics_space": space}, hidden, key) is not None
        assert _leak(task, {"n": np.array([key])}, hidden, -1).startswith("values_of_key")
        simulator = Simulator(sim_env, ctx)
        action = np.asarray(env.action_space.sample(), dtype=np.float64)
        r, sim_info = simulator.evaluate(action)
        step_obs, step_reward, _, _, step_info = env.step(action)
        task_info = TaskInfo.from_env(env)
        held = {"obs": obs, "info": info, "step": [step_obs, step_info], "sim": sim_info,
                "task_info": [task_info.env_kwargs, task_info.env_id, list(task_info.state_names)]}
        assert _leak(task, held, hidden, key) is None
        assert secret_text not in repr(held) and secret_text not in repr(task_info)
        assert r == float(step_reward)                                   # the simulator replays the context
    env.close()
    sim_env.close()


@pytest.mark.parametrize("env_id", IDS)
def test_replay_with_the_same_secret_is_bit_identical(env_id):
    env, fresh = _make(env_id, obs_mode="state"), _make(env_id, obs_mode="state")
    rng = np.random.default_rng(5)
    ctxs, acts, ref = [], [], []
    for seed in SEEDS:
        _, info = env.reset(seed=seed)
        a = rng.uniform(env.unwrapped._low64, env.unwrapped._high64)
        obs, r, _, _, inf = env.step(a)
        ctxs.append(info["context"])
        acts.append(a)
        ref.append((float(r), inf["final_pos"].tobytes(), np.asarray(obs).tobytes(), env.unwrapped.hidden_physics))
    for e in (env, fresh, pickle.loads(pickle.dumps(fresh))):
        for c, a, want in zip(ctxs, acts, ref):
            _, info = e.reset(options={"context": c})
            assert info["context"]["physics_token"] == c["physics_token"]
            obs, r, _, _, inf = e.step(a)
            assert (float(r), inf["final_pos"].tobytes(), np.asarray(obs).tobytes(),
                    e.unwrapped.hidden_physics) == want
    res = simulate_batch(env_id, ctxs, np.array(acts), workers=2, with_panda=False, obs_mode="state")
    for i, want in enumerate(ref):
        assert (float(res.reward[i]), res.final_pos[i].tobytes(), np.asarray(res.obs[i]).tobytes()) == want[:3]
    sim = Simulator(fresh, ctxs[0], workers=2)
    rewards, _ = sim.evaluate_batch(np.array([acts[0], acts[0]]))
    assert rewards.tolist() == [ref[0][0]] * 2
    env.close()
    fresh.close()


_CHILD = """
import json, sys
import numpy as np, gymnasium as gym
import phyplan_envs
env_id, seed, ctx = sys.argv[1], int(sys.argv[2]), json.loads(sys.argv[3])
env = gym.make(env_id, with_panda=False)
_, info = env.reset(seed=seed)
out = {"token": info["context"]["physics_token"], "hidden": env.unwrapped.hidden_physics}
try:
    env.reset(options={"context": {"goal": ctx["goal"], "physics_token": ctx["physics_token"]}})
    out["replay"] = repr((env.unwrapped.hidden_physics, float(env.step(np.array(ctx["action"]))[1])))
except ValueError as exc:
    out["replay"] = "ValueError: " + str(exc)
print(json.dumps(out))
"""


def _child(env_id: str, seed: int, ctx: dict, secret: str | None) -> dict:
    env = dict(os.environ)
    if secret is None:
        env.pop(SECRET_ENV)
    else:
        env[SECRET_ENV] = secret
    proc = subprocess.run([sys.executable, "-c", _CHILD, env_id, str(seed), json.dumps(ctx)], env=env, cwd=ROOT,
                          capture_output=True, text=True, timeout=300)
    assert proc.returncode == 0, proc.stderr
    return json.loads(proc.stdout.strip().splitlines()[-1])


def test_another_secret_rejects_the_context_and_the_same_secret_replays_it():
    env_id, seed = "PhyPlan/LaunchVaried-v0", SPLITS["test"][3]
    env = _make(env_id)
    _, info = env.reset(seed=seed)
    action = np.array([0.4, 1.1])
    reward = float(env.step(action)[1])
    ctx = {"goal": info["context"]["goal"].tolist(), "physics_token": info["context"]["physics_token"],
           "action": action.tolist()}
    mine = repr((env.unwrapped.hidden_physics, reward))

    same = _child(env_id, seed, ctx, os.environ[SECRET_ENV])          # a process given this process's secret
    assert same["token"] == ctx["physics_token"] and same["replay"] == mine
    for other in ("b" * 64, None):                                    # another secret; a fresh random one
        theirs = _child(env_id, seed, ctx, other)
        assert theirs["hidden"] == env.unwrapped.hidden_physics       # seeds give the same physics everywhere
        assert theirs["token"] != ctx["physics_token"]
        assert theirs["replay"].startswith("ValueError: options['context']['physics_token'] was not sealed for "
                                           "'physics:launch' under this process's secret")
        with pytest.raises(ValueError, match="was not sealed for 'physics:launch' under this process's secret"):
            env.reset(options={"context": {"goal": ctx["goal"], "physics_token": theirs["token"]}})
    env.close()


def test_tokens_are_bound_to_the_task_but_shared_by_versions():
    launch, bounce = _make("PhyPlan/LaunchVaried-v0"), _make("PhyPlan/BounceVaried-v0")
    _, info = launch.reset(seed=8)
    with pytest.raises(ValueError, match="not sealed for 'physics:bounce'"):
        bounce.reset(options={"context": {"goal": bounce.reset(seed=8)[1]["goal"],
                                          "physics_token": info["context"]["physics_token"]}})
    v0, v1 = _make("PhyPlan/SlideVaried-v0"), _make("PhyPlan/SlideVaried-v1")
    _, info = v0.reset(seed=SPLITS["test"][1])
    v1.reset(options={"context": info["context"]})
    assert v1.unwrapped.hidden_physics == v0.unwrapped.hidden_physics
    for e in (launch, bounce, v0, v1):
        e.close()


def test_seal_is_deterministic_authenticated_and_secret_dependent():
    s1, s2 = secret_bytes("a" * 32), secret_bytes("c" * 40)
    payload = (12345).to_bytes(8, "big") + b"\x01"
    t = seal(payload, "physics:slide", s1)
    assert t == seal(payload, "physics:slide", s1) and t.startswith(TOKEN_PREFIX)
    assert t != seal(payload, "physics:slide", s2) and t != seal(payload, "physics:bridge", s1)
    assert unseal(t, "physics:slide", s1, 9, "tok") == payload
    assert "12345" not in t and payload.hex() not in t and format(12345, "x") not in t
    for label, secret in (("physics:slide", s2), ("physics:bridge", s1)):
        with pytest.raises(ValueError, match="tok was not sealed for"):
            unseal(t, label, secret, 9, "tok")
    body = t[len(TOKEN_PREFIX):]
    for i in range(len(body)):                                        # every edited hex digit is rejected
        edited = TOKEN_PREFIX + body[:i] + format(int(body[i], 16) ^ 1, "x") + body[i + 1:]
        with pytest.raises(ValueError, match="tok was not sealed for"):
            unseal(edited, "physics:slide", s1, 9, "tok")
    for bad, error in ((5, TypeError), (t[:-2], ValueError), (t + "00", ValueError), ("pt1-" + "g" * 50, ValueError)):
        with pytest.raises(error, match="tok must be"):
            unseal(bad, "physics:slide", s1, 9, "tok")
    for short in ("abc", 12, "x" * 31):
        with pytest.raises(ValueError, match=f"{SECRET_ENV} must be a string of at least 32 characters"):
            secret_bytes(short)


def test_a_too_short_secret_is_refused_by_name():
    env = {**os.environ, SECRET_ENV: "short"}
    proc = subprocess.run([sys.executable, "-c", "import gymnasium as gym, phyplan_envs; "
                           "gym.make('PhyPlan/LaunchVaried-v0', with_panda=False)"], env=env, cwd=ROOT,
                          capture_output=True, text=True, timeout=300)
    assert proc.returncode != 0
    assert f"ValueError: {SECRET_ENV} must be a string of at least 32 characters" in proc.stderr
    assert "got 5 characters" in proc.stderr


def test_no_agent_reads_the_seal_or_the_privileged_values():
    """phyplan-sysid, the composed chains and every other agent plan from observations and rewards only: no agent
    module names the token, the key, the secret or the privileged accessor (module references to
    phyplan_envs.hidden_physics, for the spaces' bounds, are fine). The datasets modules (datasets.py, which reads
    them back, and dataset_writer.py) are no agents: they write the privileged values into datasets under a key
    marked privileged."""
    banned = re.compile(r"physics_token|physics_key|open_token|seal_token|_process_secret|PHYPLAN_PHYSICS_SECRET|"
                        r"SECRET_ENV|values_of_key|_physics_secret|(?<!phyplan_envs)\.hidden_physics\b")
    files = [p for p in sorted((ROOT / "phyplan_agents").rglob("*.py"))
             if p.name not in ("datasets.py", "dataset_writer.py")]
    assert any(p.name == "sysid.py" for p in files) and any(p.name == "composer.py" for p in files)
    hits = [f"{p.relative_to(ROOT)}:{i}: {line.strip()}" for p in files
            for i, line in enumerate(p.read_text().splitlines(), 1) if banned.search(line)]
    assert hits == []
    for leak in ("env.unwrapped.hidden_physics", "hp.open_token(t, k, s)", "ctx['physics_token']"):
        assert banned.search(leak)
    assert not banned.search("from phyplan_envs.hidden_physics import PAD_RADIUS")
