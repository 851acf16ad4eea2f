"""DQN baselines: grid, simulation cache, the action-conditioned SB3 policy, training, shipped models, agents."""
from __future__ import annotations

import shutil
import socket
import tempfile

import gymnasium as gym
import numpy as np
import pytest
import torch as th

import phyplan_agents
import phyplan_envs
from phyplan_agents import TaskInfo
from phyplan_agents.dqn.agents import DQNAdaptedAgent, DQNSimpleAgent
from phyplan_agents.dqn.cache import SimulationCache, get_cache, scene_name, scene_of, task_grid, train_arguments
from phyplan_agents.dqn.grid import ActionGrid
from phyplan_agents.dqn.models import ModelFileError, load_model, read_manifest, save_model, shipped_model_dir
from phyplan_agents.dqn.policy import ActionConditionedDQNPolicy
from phyplan_agents.dqn.training import CacheBanditEnv, TrainConfig, build_model, train_from_cache

from benchmarks.harness import AgentUnavailable, evaluate

th.set_num_threads(1)
TINY = TrainConfig(epochs=1, batch_size=4, features_dim=16, channels=8, keypoints=4, hidden_dim=16)


# ------------------------------------------------------------------------------------------------------------- grid
def test_grid_points_indices_and_encoding():
    g = ActionGrid((0.0, -1.0), (1.0, 1.0), (3, 5))
    pts = g.points()
    assert pts.shape == (15, 2) and g.n == 15
    assert np.allclose(pts[0], [0.0, -1.0]) and np.allclose(pts[-1], [1.0, 1.0])
    assert np.allclose(g.action(np.arange(15)), pts)
    assert np.array_equal(g.nearest(pts + 0.01), np.arange(15))
    assert g.nearest([[5.0, -9.0]])[0] == g.nearest([[1.0, -1.0]])[0]          # clipped to the box
    enc = g.encode(pts)
    assert enc.shape == (15, g.encoding_dim) and enc.dtype == np.float32
    assert np.allclose(enc[:, 0], g.normalise(pts)[:, 0]) and enc[:, 0].min() == -1 and enc[:, 0].max() == 1
    with pytest.raises(ValueError, match="out of range"):
        g.action(15)
    with pytest.raises(ValueError, match="at least 2"):
        ActionGrid((0.0,), (1.0,), (1,))


# ----------------------------------------------------------------------------------------------------------- policy
def _policy(grid: ActionGrid, size: int = 16) -> ActionConditionedDQNPolicy:
    obs = gym.spaces.Box(0, 255, (3, size, size), np.uint8)
    return ActionConditionedDQNPolicy(obs, gym.spaces.Discrete(grid.n), lambda _: 1e-3,
                                      **TINY.policy_kwargs(grid.encode(grid.points())))


def test_policy_scores_every_action_from_features_and_encoding():
    th.manual_seed(0)
    grid = ActionGrid((0.0, 0.0), (1.0, 2.0), (4, 6))
    q = _policy(grid).q_net
    obs = th.randint(0, 256, (3, 3, 16, 16), dtype=th.uint8)
    with th.no_grad():
        out = q(obs)
        feats = q.image_features(obs)
        manual = q.score(feats, th.as_tensor(grid.encode(grid.points())))
        # any continuous action, scored per image
        cont = th.as_tensor(grid.encode(np.array([[0.3, 1.7], [0.9, 0.1]])))
        per_image = q.score(feats, cont.expand(3, -1, -1))
    assert out.shape == (3, grid.n)
    assert th.allclose(out, manual, atol=1e-6)
    assert th.allclose(per_image, q.score(feats, cont), atol=1e-6)
    # the outputs come from the action encodings: permuting the grid's encodings permutes the Q-values
    perm = th.randperm(grid.n)
    with th.no_grad():
        assert th.allclose(q.score(feats, q.action_encoding[perm]), out[:, perm], atol=1e-6)
    # no per-action output units: the parameter count does not grow with the grid
    big = ActionGrid((0.0, 0.0), (1.0, 2.0), (10, 12))
    n_small = sum(p.numel() for p in q.parameters())
    n_big = sum(p.numel() for p in _policy(big).q_net.parameters())
    assert n_small == n_big


def test_policy_needs_action_encoding():
    obs = gym.spaces.Box(0, 255, (3, 16, 16), np.uint8)
    with pytest.raises(ValueError, match="action_encoding"):
        ActionConditionedDQNPolicy(obs, gym.spaces.Discrete(4), lambda _: 1e-3)


# ------------------------------------------------------------------------------------------------ cache + training
@pytest.fixture(scope="module")
def tiny_cache(tmp_path_factory):
    cache_dir = tmp_path_factory.mktemp("dqn_cache")
    cache, path, simulated = get_cache("launch", cache_dir, simulations=12, actions_per_context=4, image_size=16,
                                       grid_counts=(4, 4), seed=3, progress=False)
    assert simulated
    return cache, path, cache_dir


def test_cache_contents_and_no_resimulation(tiny_cache, monkeypatch):
    cache, path, cache_dir = tiny_cache
    assert cache.n_simulations == 12 and cache.n_contexts == 3
    assert cache.images.shape == (3, 16, 16, 3) and cache.images.dtype == np.uint8
    assert np.all(cache.seeds < 100_000)                                    # the train split
    assert np.array_equal(cache.actions, cache.grid.action(cache.action_index))
    # the rewards are the real simulator's: re-simulate one row
    env = gym.make(phyplan_envs.env_id("launch"))
    _, info = env.reset(seed=int(cache.seeds[cache.context_index[5]]))
    _, r, *_ = env.step(cache.actions[5])
    env.close()
    assert r == pytest.approx(cache.rewards[5], abs=1e-9)
    # a second request reads the file and never simulates
    monkeypatch.setattr("phyplan_agents.dqn.cache.simulate_cache",
                        lambda *a, **k: pytest.fail("re-simulated a cached task"))
    again, path2, simulated = get_cache("launch", cache_dir, simulations=12, actions_per_context=4, image_size=16,
                                        grid_counts=(4, 4), seed=3, progress=False)
    assert not simulated and path2 == path and np.array_equal(again.rewards, cache.rewards)


def test_corrupt_cache_is_named(tmp_path):
    bad = tmp_path / "x.npz"
    bad.write_bytes(b"not a zip")
    with pytest.raises(ValueError, match="x.npz"):
        SimulationCache.load(bad)


def test_bandit_env_answers_from_the_cache(tiny_cache):
    cache, _, _ = tiny_cache
    env = CacheBanditEnv(cache)
    obs, info = env.reset(seed=0)
    c = info["context_index"]
    assert obs.shape == (3, 16, 16)
    rows = np.flatnonzero(cache.context_index == c)
    _, r, terminated, _, _ = env.step(int(cache.action_index[rows[0]]))
    assert terminated and r == cache.rewards[rows[0]]
    env.reset(seed=0)
    missing = next(a for a in range(cache.grid.n) if a not in set(cache.action_index[rows]))
    with pytest.raises(LookupError, match="not simulated"):
        env.step(missing)


def test_tiny_training_run_fits_the_cache(tiny_cache, tmp_path, monkeypatch):
    cache, _, _ = tiny_cache
    temp = tmp_path / "temp"
    temp.mkdir()
    monkeypatch.delenv("SB3_LOGDIR", raising=False)
    monkeypatch.setattr(tempfile, "tempdir", str(temp))        # where SB3 would make its SB3-<date> log folder
    model, _ = build_model(cache, TINY, seed=0)
    assert model.replay_buffer.size() == cache.n_simulations                 # pre-filled, nothing collected

    def mae(q):
        with th.no_grad():
            pred = q(th.as_tensor(cache.images.transpose(0, 3, 1, 2).copy()))
        return float(np.mean(np.abs(pred[cache.context_index, cache.action_index].numpy() - cache.rewards)))

    before = mae(model.policy.q_net)
    cfg = TrainConfig(**{**TINY.__dict__, "epochs": 40})
    model, stats = train_from_cache(cache, cfg, seed=0, progress=False)
    assert stats["gradient_steps"] == 40 * 3 and np.isfinite(stats["final_loss"])
    assert mae(model.policy.q_net) < 0.5 * before
    assert list(temp.iterdir()) == []                            # training leaves nothing in the temp dir
    # saved models round-trip through the manifest with their checksum
    entry = {"task": "launch", "grid": cache.meta["grid"], "image_size": 16, "train_config": stats["config"]}
    save_model("launch", model.policy.q_net, entry, tmp_path)
    loaded = load_model("launch", tmp_path)
    with th.no_grad():
        x = th.as_tensor(cache.images[:1].transpose(0, 3, 1, 2).copy())
        assert th.allclose(loaded.q_net(x), model.policy.q_net(x), atol=1e-6)


# --------------------------------------------------------------------------------------------------- shipped models
SHIPPED = sorted(read_manifest()["models"])


def test_shipped_models_cover_the_tasks():
    assert {"launch", "slide"} <= set(SHIPPED)
    # the nominal track's tasks, and the depth track's Paddles-N for N = 1..4 (one model per scene)
    wanted = set(phyplan_envs.TRACKS["nominal"]) | {scene_name("paddles", {"paddles": n}) for n in (1, 2, 3, 4)}
    missing = sorted(wanted - set(SHIPPED))
    assert not missing, f"no shipped DQN model for {missing}: run `make baselines`"


@pytest.mark.parametrize("task", SHIPPED)
def test_shipped_models_load_offline(task, monkeypatch):
    def no_network(*args, **kwargs):
        raise AssertionError("loading a shipped model tried to use the network")

    monkeypatch.setattr(socket.socket, "connect", no_network)
    m = load_model(task)
    assert m.path.parent == shipped_model_dir() and m.path.stat().st_size < 2_000_000
    assert scene_name(m.entry["task"], m.entry.get("scene")) == task          # the model of its own scene
    grid = task_grid(m.entry["task"], None, m.entry.get("scene"))
    assert m.grid == grid
    with th.no_grad():
        q = m.q_net(th.zeros((1, 3, m.image_size, m.image_size), dtype=th.uint8))
    assert q.shape == (1, m.grid.n) and th.isfinite(q).all()


def test_corrupt_or_missing_model_file_is_named(tmp_path):
    shutil.copytree(shipped_model_dir(), tmp_path / "m")
    path = tmp_path / "m" / "launch.pt"
    data = bytearray(path.read_bytes())
    data[len(data) // 2] ^= 0xFF
    path.write_bytes(bytes(data))
    with pytest.raises(ModelFileError, match=r"launch\.pt.*corrupt"):
        load_model("launch", tmp_path / "m")
    path.unlink()
    with pytest.raises(ModelFileError, match=r"launch\.pt is missing"):
        load_model("launch", tmp_path / "m")
    with pytest.raises(ModelFileError, match="no DQN model for task 'nope'"):
        load_model("nope", tmp_path / "m")
    # an agent pointed at the broken folder fails in setup with the same message
    env = gym.make(phyplan_envs.env_id("launch"), obs_mode="image", image_size=64)
    with pytest.raises(ModelFileError, match=r"launch\.pt"):
        DQNSimpleAgent(model_dir=tmp_path / "m").setup(TaskInfo.from_env(env), 0)
    env.close()


# ------------------------------------------------------------------------------------------------- scenes (Paddles-N)
def test_scene_names_defaults_and_bad_arguments():
    assert scene_name("launch") == "launch" and scene_of("launch") == {}
    assert scene_of("paddles") == {"paddles": 3}                       # the env's default N
    assert scene_name("paddles") == scene_name("paddles", {"paddles": 3}) == "paddles-paddles3"
    assert train_arguments("paddles-paddles4") == "--task paddles --paddles 4"
    assert train_arguments("bridge") == "--task bridge"
    with pytest.raises(ValueError, match="no scene argument paddles"):
        scene_of("launch", {"paddles": 2})
    with pytest.raises(ValueError, match="paddles must be in"):
        task_grid("paddles", None, {"paddles": 0})


@pytest.mark.parametrize("n", [1, 2, 4])
def test_paddles_grid_matches_the_action_space_of_its_n(n):
    env = gym.make(phyplan_envs.env_id("paddles"), paddles=n, with_panda=False)
    grid = task_grid("paddles", None, {"paddles": n})
    assert grid.dim == env.action_space.shape[0] == n
    assert grid.counts == {1: (32,), 2: (5, 41), 4: (5, 21, 21, 21)}[n]       # phyplan_agents/dqn/grid.py
    assert np.allclose(grid.low, env.action_space.low, atol=1e-6)   # the space is float32; the grid float64
    assert np.allclose(grid.high, env.action_space.high, atol=1e-6)
    env.close()


def test_cache_model_and_agent_per_paddles_scene(tmp_path):
    """A Paddles-N cache is simulated in the env of that N and kept under the scene's name; the model trained on it
    is saved under that name, and an agent on an env of that N loads it (another N has no model: a clear error)."""
    from phyplan_agents.dqn.train import train_task

    entry = train_task("paddles", simulations=6, actions_per_context=3, image_size=16, seed=0,
                       cache_dir=tmp_path / "c", out=tmp_path / "m", config=TINY, validate=0, progress=False,
                       scene={"paddles": 2})
    assert entry["scene"] == {"paddles": 2}
    cache, path, simulated = get_cache("paddles", tmp_path / "c", 6, 3, 16, seed=0, progress=False,
                                    scene={"paddles": 2})
    assert not simulated and cache.meta["scene"] == {"paddles": 2} and cache.actions.shape == (6, 2)
    assert "paddles-paddles2" in str(path)
    # the rewards are the simulator's for that N
    env = gym.make(phyplan_envs.env_id("paddles"), paddles=2, with_panda=False)
    env.reset(seed=int(cache.seeds[cache.context_index[0]]))
    _, r, *_ = env.step(cache.actions[0])
    env.close()
    assert r == cache.rewards[0]
    agent = DQNSimpleAgent(model_dir=tmp_path / "m")
    recs = evaluate(agent, "paddles", [200_001], attempts=2, seeds=0,
                    env_kwargs={"paddles": 2, "with_panda": False})
    assert agent.model.task == "paddles-paddles2" and np.asarray(recs[0].action).shape == (2,)
    env3 = gym.make(phyplan_envs.env_id("paddles"), paddles=3, with_panda=False, obs_mode="image", image_size=16)
    with pytest.raises(ModelFileError, match=r"no DQN model for task 'paddles-paddles3'.*--task paddles --paddles 3"):
        DQNSimpleAgent(model_dir=tmp_path / "m").setup(TaskInfo.from_env(env3), 0)
    env3.close()
    with pytest.raises(AgentUnavailable, match="paddles-paddles3"):     # the harness names it too (depth skips it)
        evaluate(DQNSimpleAgent(model_dir=tmp_path / "m"), "paddles", [200_001], attempts=1, seeds=0,
                 env_kwargs={"paddles": 3, "with_panda": False})


# ------------------------------------------------------------------------------------------------------------ agents
def _run(agent, task, seed, context_seed, attempts=4):
    """The agent's actions on one context, through the harness's cell runner (it makes the agent's image env)."""
    recs = evaluate(agent, task, [context_seed], attempts=attempts, seeds=seed, env_kwargs={"with_panda": False})
    return np.array([r.action for r in recs])


@pytest.mark.parametrize("name", ["dqn-simple", "dqn-adapted"])
def test_agents_in_bounds_deterministic_and_registered(name):
    agent = phyplan_agents.make(name)
    assert isinstance(agent, DQNSimpleAgent if name == "dqn-simple" else DQNAdaptedAgent)
    assert agent.env_kwargs == {"obs_mode": "image", "image_size": 64}
    a1 = _run(agent, "launch", seed=5, context_seed=200_001)
    a2 = _run(phyplan_agents.make(name), "launch", seed=5, context_seed=200_001)
    env = gym.make(phyplan_envs.env_id("launch"))
    lo, hi = env.action_space.low, env.action_space.high
    env.close()
    assert np.all(a1 >= lo - 1e-6) and np.all(a1 <= hi + 1e-6) and np.all(np.isfinite(a1))
    assert np.array_equal(a1, a2)
    assert len({tuple(a) for a in a1}) == len(a1)                            # never the same action twice
    assert agent.stats()["sim_calls"] == 0 and agent.training_stats()["sim_calls"] > 0


def test_simple_agent_follows_the_network_ranking():
    agent = DQNSimpleAgent()
    actions = _run(agent, "slide", seed=0, context_seed=200_003, attempts=3)
    order = np.argsort(-agent._grid_q, kind="stable")[:3]
    assert np.allclose(actions, agent.model.grid.action(order))


def test_agent_renders_the_image_itself_from_a_state_observation():
    img_env = gym.make(phyplan_envs.env_id("launch"), obs_mode="image", image_size=64)
    state_env = gym.make(phyplan_envs.env_id("launch"), obs_mode="state")
    a, b = DQNSimpleAgent(), DQNSimpleAgent()
    a.setup(TaskInfo.from_env(img_env), 0)
    b.setup(TaskInfo.from_env(state_env), 0)
    obs, info = img_env.reset(seed=200_002)
    a.begin_context(obs, info)
    obs_s, info_s = state_env.reset(seed=200_002)
    assert obs_s.ndim == 1
    b.begin_context(obs_s, info_s)
    assert np.allclose(a._grid_q, b._grid_q, atol=1e-5)
    b.close()
    img_env.close()
    state_env.close()


def test_adapted_agent_rejects_bad_options():
    with pytest.raises(ValueError):
        DQNAdaptedAgent(beta=-1)
    with pytest.raises(TypeError, match="unknown options"):
        DQNAdaptedAgent(nonsense=1)


def test_dqn_eval_cli_prints_the_harness_figures(capsys):
    from benchmarks import dqn_eval, report, splits, stats

    dqn_eval.main(["--task", "launch", "--agent", "dqn-simple", "--contexts", "3", "--attempts", "2", "--seeds", "2"])
    row = [line for line in capsys.readouterr().out.splitlines() if line.startswith("| launch | dqn-simple |")]
    assert len(row) == 1
    # the same cells as the harness: its summary's mean and Student-t interval over contexts
    recs = evaluate("dqn-simple", "launch", splits.context_seeds("test", 3), attempts=2, seeds=[0, 1])
    (summary,) = report.summarize(recs)
    mean, half = dqn_eval.regret_table_row(recs, 2)
    assert mean.tolist() == summary.regret
    np.testing.assert_allclose(mean - half, summary.regret_low, rtol=0, atol=1e-15)
    assert f"{summary.regret[0]:.3f} ± {half[0]:.3f}" in row[0]
    with pytest.raises(ValueError, match="KEY=VALUE"):
        dqn_eval.parse_agent_kw(["optimize"])
    assert dqn_eval.parse_agent_kw(["optimize=True", "x=abc"]) == {"optimize": True, "x": "abc"}
    assert stats.half_width([[0.1], [0.1]]).tolist() == [0.0]


def test_grid_check_exhaustive_equals_brute_force():
    """``benchmarks.dqn_grid --exhaustive`` with every grid action verified is the brute-force best grid action."""
    from benchmarks import splits
    from benchmarks.dqn_grid import exhaustive_best
    from phyplan_agents.dqn.cache import make_env, task_grid

    grid = task_grid("launch", (4, 3))
    env = make_env("launch", obs_mode="state")
    infos = [env.reset(seed=int(s))[1] for s in splits.context_seeds("dev", 2)]
    brute = []
    for info in infos:
        rewards = []
        for a in grid.points():
            env.reset(options={"context": info["context"]})
            rewards.append(env.step(a)[1])
        brute.append(max(rewards))
    env.close()
    full = exhaustive_best("launch", grid, infos, verify=grid.n, workers=1)
    assert full["grid_reward"].tolist() == brute and full["simulations"] == grid.n * 3
    top = exhaustive_best("launch", grid, infos, verify=2, workers=1)
    assert np.all(top["grid_reward"] <= full["grid_reward"]) and 0.0 <= top["agree"] <= 1.0
