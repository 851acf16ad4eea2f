"""Minari datasets (phyplan_agents.datasets, python -m benchmarks.datasets) and the DQN cache through them.

Tiny datasets of the random policy on one cheap task (Launch) and one varied task (SlideVaried, with images): Minari's
integrity checks, the recovered env replaying every episode bit for bit, the privileged hidden physics, the same
arguments giving the same files, refused arguments, no network; and the DQN cache written and read as a dataset
equal to the ``.npz`` format, training the same weights.
"""
from __future__ import annotations

import configparser
import json
import socket
import subprocess
import sys
import textwrap
from pathlib import Path

import numpy as np
import pytest

pytest.importorskip("minari")

import phyplan_envs  # noqa: E402
from benchmarks import datasets as cli  # noqa: E402
from phyplan_agents import datasets as pds  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]
LAUNCH = ["--tasks", "launch", "--episodes", "6", "--attempts-per-context", "2", "--no-progress"]
VARIED = ["--tasks", "slide-varied", "--episodes", "3", "--images", "--image-size", "32", "--no-progress"]


def _files(root: Path, ds_id: str) -> dict[str, bytes]:
    folder = pds.dataset_dir(root, ds_id)
    return {str(f.relative_to(folder)): f.read_bytes() for f in sorted(folder.rglob("*")) if f.is_file()}


@pytest.fixture(scope="module")
def built(tmp_path_factory):
    """Both datasets built by the CLI with every socket refused (no network at run time)."""
    out = tmp_path_factory.mktemp("minari")
    with pytest.MonkeyPatch.context() as mp:
        def refuse(*a, **k):
            raise AssertionError("a dataset build opened a network connection")
        mp.setattr(socket.socket, "connect", refuse)
        mp.setattr(socket, "create_connection", refuse)
        assert cli.main([*LAUNCH, "--out", str(out)]) == 0
        assert cli.main([*VARIED, "--out", str(out)]) == 0
    return out


def _load(out, task):
    return pds.load(out, pds.dataset_id(task, "random"))


def test_integrity_counts_and_spaces(built):
    minari = pds.require_minari()
    with pds.datasets_root(built):
        assert {"phyplan/launch/random-v0", "phyplan/slide-varied/random-v0"} <= set(minari.list_local_datasets())
    for task, n, obs_mode in (("launch", 6, "state"), ("slide-varied", 3, "state_image")):
        ds = _load(built, task)
        pds.check_dataset(ds, n)
        assert ds.spec.total_episodes == ds.spec.total_steps == n
        env = ds.recover_environment()
        assert env.spec.id == phyplan_envs.env_id(task)
        kwargs = {"obs_mode": obs_mode, "with_panda": False, **({"image_size": 32} if obs_mode != "state" else {})}
        assert env.spec.kwargs == kwargs
        assert ds.observation_space == env.observation_space
        base = env.unwrapped
        assert ds.action_space.dtype == np.float64
        assert ds.action_space.low.tolist() == [d.low for d in base.action_dims]
        meta = ds.storage.metadata["phyplan"]
        assert meta["task"] == task and meta["policy"] == "random" and meta["split"] == "train"
        env.close()
    launch = _load(built, "launch")
    seeds = [pds.episode_seed(ep) for ep in launch]
    assert [int(ep.infos["attempt"][1]) for ep in launch] == [1, 2] * 3
    assert seeds[0::2] == seeds[1::2] and len(set(seeds)) == 3
    assert all(phyplan_envs.splits.split_of(s) == "train" for s in seeds)


def test_the_check_catches_a_damaged_dataset(built, tmp_path):
    import shutil

    ds_id = pds.dataset_id("launch", "random")
    shutil.copytree(pds.dataset_dir(built, ds_id), pds.dataset_dir(tmp_path, ds_id))
    meta_file = pds.dataset_dir(tmp_path, ds_id) / "data" / "metadata.json"
    meta = json.loads(meta_file.read_text())
    meta["total_episodes"] = 7
    meta_file.write_text(json.dumps(meta))
    with pytest.raises(AssertionError, match="7 episodes"):
        pds.check_dataset(pds.load(tmp_path, ds_id))
    with pytest.raises(AssertionError, match="expected 5"):
        pds.check_dataset(_load(built, "launch"), 5)


def test_recovered_env_replays_every_episode(built):
    for task in ("launch", "slide-varied"):
        ds = _load(built, task)
        env = ds.recover_environment()
        for ep in ds:
            for how in ("context", "seed") + (("physics",) if task == "slide-varied" else ()):
                obs, reward, terminated, _, info = pds.replay(env, ep, how)
                assert terminated and reward == ep.rewards[0], (task, how, ep.id)
                state = obs["state"] if isinstance(obs, dict) else obs
                stored = ep.observations["state"] if isinstance(ep.observations, dict) else ep.observations
                assert np.array_equal(state, stored[1])
                assert np.array_equal(info["final_pos"], ep.infos["object_pos"][1])
                assert info["distance"] == ep.infos["distance"][1]
                assert info["end_reason"] == pds.info_row(ep.infos["end_reason"]).decode()
        env.close()


def test_a_varied_dataset_replays_in_another_process_by_seed_or_physics(built):
    """Another process has another secret: the stored sealed context is refused there, the seed and the privileged
    physics replay every episode bit for bit."""
    import os

    code = textwrap.dedent(f"""
        import pytest
        from phyplan_agents import datasets as pds
        ds = pds.load({str(built)!r}, "phyplan/slide-varied/random-v0")
        env = ds.recover_environment()
        for ep in ds:
            assert [pds.replay(env, ep, how)[1] for how in ("seed", "physics")] == [ep.rewards[0]] * 2
            with pytest.raises(ValueError, match="not sealed"):
                pds.replay(env, ep, "context")
        print("ok")
    """)
    env = {k: v for k, v in os.environ.items() if k != "PHYPLAN_PHYSICS_SECRET"}
    r = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, cwd=ROOT, env=env, timeout=120)
    assert r.returncode == 0 and r.stdout.strip().endswith("ok"), r.stderr[-2000:]


def test_privileged_hidden_physics_only_on_varied_tasks(built):
    assert all(pds.HIDDEN_KEY not in ep.infos for ep in _load(built, "launch"))
    ds = _load(built, "slide-varied")
    env = ds.recover_environment()
    names = [p.name for p in env.unwrapped.hidden_parameters]
    assert ds.storage.metadata["phyplan"]["hidden_physics"] == names
    for ep in ds:
        hidden = ep.infos[pds.HIDDEN_KEY]
        assert sorted(hidden) == sorted(names)
        env.reset(seed=pds.episode_seed(ep))
        assert {k: float(v[0]) for k, v in hidden.items()} == env.unwrapped.hidden_physics
        text = pds.info_row(ep.infos["context"]).decode()
        assert all(repr(float(v[0]))[:7] not in text for v in hidden.values())     # the context hides them
    env.close()


def test_images_are_the_obs_camera_as_jpeg(built):
    ds = _load(built, "slide-varied")
    env = ds.recover_environment()
    ep = ds[0]
    assert ep.observations["image"].shape == (2, 32, 32, 3) and ep.observations["image"].dtype == np.uint8
    obs, _ = env.reset(options={"context": pds.episode_context(ep)})
    err = np.abs(obs["image"].astype(int) - ep.observations["image"][0])
    assert 0 < err.mean() < 8           # JPEG: close to the rendered frame, not equal to it
    env.close()


def test_same_arguments_same_files(built, tmp_path):
    cli.main([*LAUNCH, "--out", str(tmp_path)])
    cli.main([*VARIED, "--out", str(tmp_path)])       # same process: the same secret seals the physics tokens
    for task in ("launch", "slide-varied"):
        ds_id = pds.dataset_id(task, "random")
        assert _files(tmp_path, ds_id) == _files(built, ds_id), task
    a, b = _load(built, "launch"), _load(tmp_path, "launch")
    for x, y in zip(a, b):
        assert np.array_equal(x.observations, y.observations) and np.array_equal(x.actions, y.actions)
    cli.main([*LAUNCH, "--out", str(tmp_path), "--seed", "1", "--overwrite"])
    assert not np.array_equal(_load(tmp_path, "launch")[0].actions, a[0].actions)


@pytest.mark.parametrize("args, message", [
    (["--tasks", "nope", "--episodes", "2"], "argument --tasks: unknown task"),
    (["--tasks", "launch", "--episodes", "2", "--policy", "nope"], "argument --policy: invalid choice"),
    (["--tasks", "launch", "--episodes", "0"], "argument --episodes: must be >= 1"),
    (["--tasks", "launch", "--episodes", "2", "--split", "test"], "argument --split: .*--allow-test-split"),
    (["--tasks", "launch", "--episodes", "2", "--attempts-per-context", "0"], "argument --attempts-per-context"),
    (["--tasks", "launch", "--episodes", "1001", "--split", "dev"], "argument --episodes: 1001 contexts"),
])
def test_bad_arguments_are_named(args, message, tmp_path, capsys):
    with pytest.raises(SystemExit):
        cli.main([*args, "--out", str(tmp_path)])
    assert __import__("re").search(message, capsys.readouterr().err)
    assert not any(tmp_path.iterdir())


def test_an_existing_dataset_needs_overwrite(built, capsys):
    before = _files(built, pds.dataset_id("launch", "random"))
    with pytest.raises(SystemExit):
        cli.main([*LAUNCH, "--out", str(built)])
    err = capsys.readouterr().err
    assert "argument --out" in err and "--overwrite" in err
    assert _files(built, pds.dataset_id("launch", "random")) == before
    with pytest.raises(FileExistsError, match="overwrite"):
        cli.build("launch", "random", 2, built)


def test_extra_is_declared():
    cfg = configparser.ConfigParser()
    cfg.read(ROOT / "setup.cfg")
    extras = cfg["options.extras_require"]
    assert "minari[hdf5]==0.5.3" in extras["datasets"].split() and "minari[hdf5]==0.5.3" in extras["dev"].split()
    assert "minari" not in cfg["options"]["install_requires"]


def test_core_imports_without_minari(tmp_path):
    code = textwrap.dedent(f"""
        import sys
        sys.modules["minari"] = sys.modules["h5py"] = None     # as if not installed: imports fail
        import phyplan_envs, phyplan_agents, benchmarks.datasets
        from phyplan_agents import datasets as pds
        from phyplan_agents.dqn import cache
        assert not pds.minari_available()
        try:
            pds.require_minari()
        except ImportError as e:
            assert "pip install 'phyplan[datasets]'" in str(e), e
        else:
            raise SystemExit("minari imported")
        c, path, sim = cache.get_cache("launch", {str(tmp_path)!r}, 4, 2, 16, (4, 4), 0, progress=False)
        assert sim and path.suffix == ".npz" and c.n_simulations == 4, path
        try:
            benchmarks.datasets.main(["--tasks", "launch", "--episodes", "1", "--out", {str(tmp_path)!r}])
        except SystemExit as e:
            assert e.code == 2
        else:
            raise SystemExit("the CLI ran without Minari")
        print("ok")
    """)
    r = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, cwd=ROOT, timeout=120)
    assert r.returncode == 0 and r.stdout.strip().endswith("ok"), r.stderr[-2000:]
    assert "phyplan[datasets]" in r.stderr


# ------------------------------------------------------------------------------------------------ the DQN cache
def test_dqn_cache_through_the_dataset_equals_the_npz_cache(tmp_path, monkeypatch):
    import torch as th

    from phyplan_agents.dqn import cache as C
    from phyplan_agents.dqn.training import TrainConfig, train_from_cache

    args = dict(simulations=12, actions_per_context=4, image_size=16, grid_counts=(4, 4), seed=3, progress=False)
    with monkeypatch.context() as m:
        m.setattr(pds, "minari_available", lambda: False)
        old, old_path, _ = C.get_cache("launch", tmp_path / "npz", **args)
    new, new_path, simulated = C.get_cache("launch", tmp_path / "ds", **args)
    assert old_path.suffix == ".npz" and (new_path / "data" / "main_data.hdf5").exists() and simulated
    monkeypatch.setattr(C, "simulate_cache", lambda *a, **k: pytest.fail("re-simulated a cached task"))
    again, path, simulated = C.get_cache("launch", tmp_path / "ds", **args)
    assert path == new_path and not simulated
    for name in ("images", "seeds", "goals", "context_index", "action_index", "actions", "rewards"):
        a = getattr(old, name)
        for b in (getattr(new, name), getattr(again, name)):
            assert a.dtype == b.dtype and np.array_equal(a, b), name
    pds.check_dataset(pds.load(tmp_path / "ds" / "minari", new.meta["dataset"]), 12)
    # an .npz cache is still read where the dataset is missing
    import shutil

    shutil.copy(old_path, tmp_path / "ds" / old_path.name)
    shutil.rmtree(new_path)
    npz, path, simulated = C.get_cache("launch", tmp_path / "ds", **args)
    assert path.suffix == ".npz" and not simulated and np.array_equal(npz.rewards, old.rewards)
    tiny = TrainConfig(epochs=2, batch_size=4, features_dim=16, channels=8, keypoints=4, hidden_dim=16)
    weights = [train_from_cache(c, tiny, seed=0, progress=False)[0].policy.state_dict() for c in (old, again)]
    assert all(th.equal(weights[0][k], weights[1][k]) for k in weights[0])


def test_dqn_cache_from_a_policy_dataset(built):
    from phyplan_agents.dqn.dataset_io import cache_from_dataset

    ds = _load(built, "launch")
    with pytest.raises(ValueError, match="snap=True"):
        cache_from_dataset(ds, image_size=16)
    cache = cache_from_dataset(ds, image_size=16, snap=True)
    assert cache.n_simulations == 6 and cache.n_contexts == 3 and cache.images.shape == (3, 16, 16, 3)
    assert np.array_equal(cache.rewards, [ep.rewards[0] for ep in ds])
    assert cache.meta["snapped"] == 6
    with pytest.raises(ValueError, match="nominal tasks"):
        cache_from_dataset(_load(built, "slide-varied"))
