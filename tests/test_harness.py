"""Tests of the benchmark harness (benchmarks/): splits, regret/AUC maths, protocol records, failures, resume,
parallel and Ray backends, the CLI's errors, and a third-party agent defined in tests/third_party_agent.py."""
from __future__ import annotations

import dataclasses
import json
import math
import os
import shutil
import signal
import subprocess
import sys
import time
from pathlib import Path

import gymnasium as gym
import numpy as np
import pytest

import phyplan_envs
from benchmarks import harness, report, run, splits
from benchmarks.harness import AttemptRecord, RunConfig

REPO = Path(__file__).resolve().parents[1]
MY_AGENT = "tests.third_party_agent:MyAgent"
BAD_AGENT = "tests.third_party_agent:MisbehavingAgent"


@pytest.fixture(autouse=True)
def _repo_on_path(monkeypatch):
    # "tests.third_party_agent:..." must import here and in spawned workers (which inherit sys.path)
    monkeypatch.syspath_prepend(str(REPO))


def _rec(task="launch", agent="a", seed=0, context=200000, attempt=1, reward=0.0, success=False, **kw):
    base = dict(task=task, agent=agent, seed=seed, context=context, split="test", attempt=attempt, action=None,
                reward=reward, best=None, regret=1.0, success=success, solved=False, distance=None, begin_time=0.0,
                act_time=0.001, step_time=0.01, observe_time=0.0, sim_calls=0, skill_evals=0.0,
                error=None if reward is not None else "act: failed")
    base.update(kw)
    return AttemptRecord(**base)


def _comparable(summaries):
    """Summaries without their wall-clock fields."""
    out = []
    for s in summaries:
        d = dataclasses.asdict(s)
        d.pop("agent_time")
        d.pop("env_time")
        out.append(d)
    return out


def _keyed(records):
    return {r.cell + (r.attempt,): r.without_timing() for r in records}


# ================================================================================================= splits
def test_splits_are_disjoint_and_documented():
    ranges = list(splits.SPLITS.values())
    for i, a in enumerate(ranges):
        for b in ranges[i + 1:]:
            assert max(a.start, b.start) >= min(a.stop, b.stop), "splits overlap"
    assert splits.train_seeds(3) == [0, 1, 2]
    assert splits.context_seeds("test", 2) == [200000, 200001]
    assert splits.split_of(200005) == "test" and splits.split_of(150000) is None
    picked = splits.sample_seeds("train", 5, np.random.default_rng(0))
    assert len(set(picked)) == 5 and all(splits.split_of(s) == "train" for s in picked)
    splits.assert_train_seeds(picked)
    with pytest.raises(ValueError, match="outside the train split"):
        splits.assert_train_seeds([1, 200000])
    with pytest.raises(ValueError, match="available splits: train, dev, test"):
        splits.context_seeds("val", 3)
    with pytest.raises(ValueError, match="only 1000 contexts"):
        splits.context_seeds("test", 1001)
    # a context id is what env.reset(seed=id) samples, in any process
    ctx = splits.make_context("launch", 200000)
    env = gym.make(phyplan_envs.env_id("launch"))
    _, info = env.reset(seed=200000)
    np.testing.assert_array_equal(info["context"]["goal"], ctx["goal"])


# ========================================================================================= regret and AUC maths
def test_regret_curve_by_hand():
    np.testing.assert_allclose(report.regret_curve([0.2, None, 0.5, -0.3, 0.9]), [0.8, 0.8, 0.5, 0.5, 0.1])
    np.testing.assert_allclose(report.regret_curve([None, None]), [1.0, 1.0])     # nothing ran yet
    np.testing.assert_allclose(report.regret_curve([-0.5, 1.2]), [1.5, 0.0])     # negative rewards, capped at 0


def test_auc_weights_are_phyre_weights():
    w = report.auc_weights(5)
    raw = np.array([math.log(k + 1) - math.log(k) for k in range(1, 6)])
    np.testing.assert_allclose(w, raw / math.log(6))
    np.testing.assert_allclose(w, [0.3869, 0.2263, 0.1606, 0.1245, 0.1018], atol=1e-4)
    assert report.weighted_area([1, 1, 1]) == pytest.approx(1.0)
    assert report.weighted_area([1, 0]) == pytest.approx(math.log(2) / math.log(3))
    with pytest.raises(ValueError):
        report.auc_weights(0)


def test_the_one_interval_by_hand():
    from benchmarks import stats

    ids, means = stats.per_context([[1.0, 0.0], [3.0, 2.0], [0.0, 0.0], [5.0, 4.0]], [7, 5, 7, 5])
    assert ids == [5, 7] and means.tolist() == [[4.0, 3.0], [0.5, 0.0]]
    x = np.array([0.1, 0.4, 0.7])                       # sd 0.3, n 3, t(0.975, 2) = 4.302652729911275
    mean, lo, hi = stats.mean_ci(x)
    half = 4.302652729911275 * 0.3 / math.sqrt(3)
    assert mean == pytest.approx(0.4) and lo == pytest.approx(0.4 - half) and hi == pytest.approx(0.4 + half)
    assert stats.half_width(x) == pytest.approx(half)
    assert np.isnan(stats.mean_ci([0.3])[1])            # one context: no interval
    assert report.mean_ci is stats.mean_ci
    with pytest.raises(ValueError, match="level"):
        stats.mean_ci(x, level=95)
    with pytest.raises(ValueError, match="rows"):
        stats.per_context([1.0, 2.0], [1])
    recs = [_rec(seed=s, context=c, attempt=k, regret=reg) for s, c, k, reg in
            [(1, 9, 1, 0.5), (1, 9, 2, 0.1), (0, 9, 1, 0.3), (0, 9, 2, 0.3), (0, 4, 2, 0.0), (0, 4, 1, 0.2)]]
    ids, curves = stats.regret_per_context(recs)
    assert ids == [4, 9] and curves.tolist() == [[0.2, 0.0], [0.4, 0.2]]
    with pytest.raises(ValueError, match="lack some of the attempts"):
        stats.regret_per_context(recs[:-1])


def test_summary_on_hand_made_records():
    # two contexts x two seeds, 3 attempts; context 1 is easy, context 2 hard; one failed attempt
    rewards = {(0, 1): [0.5, 0.9, 0.8], (1, 1): [0.7, 0.6, 1.0], (0, 2): [None, 0.1, 0.3], (1, 2): [0.2, 0.2, 0.4]}
    success = {(0, 1): [False, True, False], (1, 1): [False, False, True]}
    recs = []
    for (seed, ctx), rs in rewards.items():
        for k, r in enumerate(rs, start=1):
            recs.append(_rec(agent="x", seed=seed, context=ctx, attempt=k, reward=r,
                             success=success.get((seed, ctx), [False] * 3)[k - 1], sim_calls=k, skill_evals=10.0))
    recs += [_rec(agent="oracle", context=1, attempt=k, reward=1.0, success=True) for k in (1, 2, 3)]
    (s, bound) = report.summarize(recs, bound_agents=["oracle"])
    assert bound.agent == "oracle" and bound.is_bound and not s.is_bound
    # per cell regrets: (0,1) .5 .1 .1 ; (1,1) .3 .3 0 ; (0,2) 1 .9 .7 ; (1,2) .8 .8 .6
    ctx1 = np.array([[0.5, 0.1, 0.1], [0.3, 0.3, 0.0]]).mean(axis=0)
    ctx2 = np.array([[1.0, 0.9, 0.7], [0.8, 0.8, 0.6]]).mean(axis=0)
    np.testing.assert_allclose(s.regret, (ctx1 + ctx2) / 2)
    half = 12.7062047 * np.abs(ctx1 - ctx2) / math.sqrt(2) / math.sqrt(2)    # t(0.975, 1) * sd / sqrt(n)
    np.testing.assert_allclose(np.array(s.regret_high) - s.regret, half, rtol=1e-6)
    w = report.auc_weights(3)
    assert s.auc == pytest.approx(float(w @ ((ctx1 + ctx2) / 2)))
    np.testing.assert_allclose(s.success, [0.0, 0.25, 0.5])
    assert s.success_rate == 0.5 and s.auccess == pytest.approx(float(w @ [0.0, 0.25, 0.5]))
    assert s.failed == 1 and s.failure_example == "act: failed"
    assert s.sim_calls == pytest.approx(2.0) and s.skill_evals == pytest.approx(10.0)
    assert s.agent_time == pytest.approx(0.001) and s.env_time == pytest.approx(0.01)
    text = report.format_markdown([s, bound])
    assert "oracle (bound)" in text and "act: failed" in text
    with pytest.raises(ValueError, match="expected 1..3"):
        report.summarize(recs[:-1], attempts=3)


def test_paper_numbers_beside_ours(tmp_path):
    recs = [_rec(agent="random", attempt=k, reward=0.1 * k) for k in range(1, 6)]
    summaries, text = report.write_report(recs, tmp_path, {"attempts": 5})
    assert summaries[0].paper == (0.69, 0.49)
    assert ".69 → .49" in text
    assert (tmp_path / "summary.csv").read_text().splitlines()[1].split(",")[17:19] == ["0.69", "0.49"]
    from benchmarks.paper_reference import format_paper
    assert format_paper("slide", "phyplan") == ".142 → .10" and format_paper("launch", "phyplan") == "≈.13 → .085"
    assert format_paper("launch", "oracle") == ""
    assert (tmp_path / "regret_launch.png").stat().st_size > 1000 and (tmp_path / "runtime.png").exists()


# ================================================================================================ protocol
def test_records_follow_the_protocol(tmp_path):
    cfg = RunConfig(tasks=["launch"], agents=["random", MY_AGENT, "tests.third_party_agent:SimAgent"],
                    contexts=2, attempts=3, seeds=1)
    records = harness.run(cfg, tmp_path, progress=False, log=lambda m: None).records
    assert len(records) == 3 * 2 * 3
    env = gym.make(phyplan_envs.env_id("launch"))
    low, high = env.unwrapped.action_space.low, env.unwrapped.action_space.high
    for cell in {r.cell for r in records}:
        recs = sorted((r for r in records if r.cell == cell), key=lambda r: r.attempt)
        best = -np.inf
        for r in recs:
            assert r.error is None and r.split == "test"
            best = max(best, r.reward)
            assert r.best == pytest.approx(best) and r.regret == pytest.approx(max(0.0, 1 - best))
            assert np.all(np.asarray(r.action) >= low - 1e-6) and np.all(np.asarray(r.action) <= high + 1e-6)
        # the attempt really was this action on this context
        last = recs[-1]
        env.reset(seed=last.context)
        _, reward, *_ = env.step(np.asarray(last.action))
        assert reward == last.reward
    mine = [r for r in records if r.agent == MY_AGENT]
    assert all(r.skill_evals == 1 for r in mine)              # the agent's stats() difference per attempt
    sim = sorted((r for r in records if r.agent.endswith("SimAgent") and r.context == 200000), key=lambda r: r.attempt)
    assert [r.sim_calls for r in sim] == [5, 2, 2]            # 3 in begin_context (charged to attempt 1) + 2 per act
    rnd = [r for r in records if r.agent == "random"]
    assert all(r.sim_calls == 0 for r in rnd)


def test_bad_actions_and_agent_exceptions_are_failed_attempts(tmp_path):
    cfg = RunConfig(tasks=["launch"], agents=[BAD_AGENT], contexts=1, attempts=6, seeds=1)
    records = harness.run(cfg, tmp_path, progress=False, log=lambda m: None).records
    bad = sorted((r for r in records if r.agent == BAD_AGENT), key=lambda r: r.attempt)
    reasons = [r.error or "" for r in bad]
    assert reasons[0].startswith("bad_action:") and "non-finite" in reasons[0]
    assert reasons[1].startswith("bad_action:") and "shape (3,)" in reasons[1]
    assert reasons[2].startswith("bad_action:") and "out of bounds" in reasons[2] and "phi=" in reasons[2]
    assert reasons[3].startswith("act: RuntimeError: planner exploded")
    for r in bad[:4]:
        assert r.reward is None and r.best is None and r.regret == 1.0 and r.action is None
    assert bad[4].error is None and bad[4].reward is not None
    assert bad[5].error.startswith("bad_action:")               # cycle restarts; regret stays where it was
    assert bad[5].regret == bad[4].regret and bad[5].best == bad[4].best
    summaries = report.summarize(records)
    assert {s.agent: s.failed for s in summaries} == {BAD_AGENT: 5}


def test_an_error_in_observe_keeps_the_reward(tmp_path):
    cfg = RunConfig(tasks=["launch"], agents=["tests.third_party_agent:ObserveFailsAgent", "random"], contexts=1,
                    attempts=2, seeds=1)
    records = harness.run(cfg, tmp_path, progress=False, log=lambda m: None).records
    broken = [r for r in records if r.agent != "random"]
    same_draws = [r for r in records if r.agent == "random"]    # the same seeded draws, without the error
    assert [r.reward for r in broken] == [r.reward for r in same_draws]
    assert all(r.error.startswith("observe: KeyError") for r in broken)
    assert broken[-1].regret == same_draws[-1].regret
    assert {s.agent: s.failed for s in report.summarize(records)}["tests.third_party_agent:ObserveFailsAgent"] == 2


def test_an_agent_whose_setup_fails_is_reported_not_recorded(tmp_path):
    broken = "tests.third_party_agent:SetupFailsAgent"
    cfg = RunConfig(tasks=["launch"], agents=["random", broken], contexts=2, attempts=2, seeds=2)
    result = harness.run(cfg, tmp_path, workers=1, progress=False, log=lambda m: None)
    assert {r.agent for r in result.records} == {"random"} and len(result.records) == 2 * 2 * 2
    assert set(result.unavailable) == {("launch", broken, 0), ("launch", broken, 1)}
    assert all(v.startswith("setup: FileNotFoundError: weights.pt not found") for v in result.unavailable.values())
    (line,) = harness.describe_unavailable(result.unavailable)
    assert "seeds [0, 1]" in line and "weights.pt not found" in line
    again = harness.run(cfg, tmp_path, progress=False, log=lambda m: None)   # a rerun tries it again
    assert again.ran == 4 and len(again.unavailable) == 2


def test_agents_choose_their_observation(tmp_path):
    cfg = RunConfig(tasks=["launch"], agents=["tests.third_party_agent:ImageAgent"], contexts=1, attempts=2, seeds=1)
    result = harness.run(cfg, tmp_path, progress=False, log=lambda m: None)
    assert not result.unavailable and [r.error for r in result.records] == [None, None]


def test_without_timing_drops_every_wall_clock_field():
    a = _rec(agent_stats={"skill_evals": 3.0, "plan_seconds": 0.25, "sim_calls": 0.0},
             training={"sim_calls": 2000, "train_seconds": 12.0, "fit_time": 1.0})
    b = dataclasses.replace(a, begin_time=9.0, act_time=9.0, step_time=9.0, observe_time=9.0,
                            agent_stats={**a.agent_stats, "plan_seconds": 7.5},
                            training={**a.training, "train_seconds": 30.0, "fit_time": 2.0})
    assert a.without_timing() == b.without_timing()
    assert "plan_seconds" not in a.without_timing()["agent_stats"]
    assert a.without_timing()["agent_stats"] == {"skill_evals": 3.0, "sim_calls": 0.0}
    # anything that is not a timing still counts
    c = dataclasses.replace(a, agent_stats={**a.agent_stats, "skill_evals": 4.0})
    assert a.without_timing() != c.without_timing()
    assert a.without_timing() != dataclasses.replace(a, reward=0.5).without_timing()


def test_evaluate_gives_the_records_of_run(tmp_path):
    cfg = RunConfig(tasks=["launch"], agents=["random", "tests.third_party_agent:SimAgent"], contexts=2, attempts=3,
                    seeds=2)
    ran = _keyed(harness.run(cfg, tmp_path, progress=False, log=lambda m: None).records)
    ctxs = splits.context_seeds("test", 2)
    for name in cfg.agents:
        recs = harness.evaluate(name, "launch", ctxs, attempts=3, seeds=[0, 1])
        assert [(r.seed, r.context, r.attempt) for r in recs] == [(s, c, k) for s in (0, 1) for c in ctxs
                                                                  for k in (1, 2, 3)]
        assert {k: v for k, v in ran.items() if k[1] == name} == _keyed(recs)
    # an agent object is set up by the harness and can be inspected afterwards; records carry its name
    from tests.third_party_agent import SimAgent

    agent = SimAgent()
    recs = harness.evaluate(agent, "launch", ctxs[:1], attempts=3, seeds=1)
    assert {r.agent for r in recs} == {"sim-agent"} and agent.task.task == "launch" and len(agent.history) == 3
    assert [r.reward for r in recs] == [ran[("launch", "tests.third_party_agent:SimAgent", 1, ctxs[0], k)]["reward"]
                                        for k in (1, 2, 3)]


def test_evaluate_raises_on_failures_and_bad_arguments():
    with pytest.raises(RuntimeError, match=r"context 200000, attempt 1: bad_action: .*non-finite"):
        harness.evaluate(BAD_AGENT, "launch", [200000], attempts=2)
    recs = harness.evaluate(BAD_AGENT, "launch", [200000], attempts=2, errors="record")
    assert all(r.error.startswith("bad_action:") for r in recs)
    with pytest.raises(RuntimeError, match="could not be set up.*weights.pt"):
        harness.evaluate("tests.third_party_agent:SetupFailsAgent", "launch", [200000], attempts=1)
    with pytest.raises(ValueError, match="unknown task"):
        harness.evaluate("random", "nope", [200000])
    with pytest.raises(ValueError, match="attempts"):
        harness.evaluate("random", "launch", [200000], attempts=0)
    with pytest.raises(ValueError, match="contexts is empty"):
        harness.evaluate("random", "launch", [])
    with pytest.raises(ValueError, match="errors"):
        harness.evaluate("random", "launch", [200000], errors="ignore")


def test_validate_action_reasons():
    lo, hi = np.array([0.0, 0.5]), np.array([1.0, 1.5])
    ok, why = harness.validate_action([1.0 + 5e-7, 0.5], lo, hi, ("a", "b"))
    assert why is None and ok[0] == 1.0                         # within float32 rounding of the bound: clipped
    assert "not numeric" in harness.validate_action("left", lo, hi, ("a", "b"))[1]
    assert "shape (2, 2)" in harness.validate_action(np.zeros((2, 2)), lo, hi, ("a", "b"))[1]
    assert "b=2" in harness.validate_action([0.5, 2.0], lo, hi, ("a", "b"))[1]
    assert "['a']" in harness.validate_action([np.inf, 1.0], lo, hi, ("a", "b"))[1]


# ============================================================================================ resume
def test_resume_after_truncation_gives_identical_summaries(tmp_path):
    cfg = RunConfig(tasks=["launch", "slide"], agents=["random", MY_AGENT], contexts=2, attempts=3, seeds=2)
    full_dir, cut_dir = tmp_path / "full", tmp_path / "cut"
    full = harness.run(cfg, full_dir, progress=False, log=lambda m: None).records
    # an interrupted run: the file stops in the middle of a line, in the middle of a cell
    cut_dir.mkdir()
    shutil.copy(full_dir / "config.json", cut_dir / "config.json")
    raw = (full_dir / "attempts.jsonl").read_bytes()
    cut_at = raw.index(b"\n", len(raw) // 2) + 40
    (cut_dir / "attempts.jsonl").write_bytes(raw[:cut_at])
    kept, dropped = harness.load_records(cut_dir / "attempts.jsonl", 3)
    assert dropped >= 1 and len(kept) % 3 == 0 and len(kept) < len(full)
    logs = []
    resumed = harness.run(cfg, cut_dir, progress=False, log=logs.append).records
    assert any("resuming" in m for m in logs)
    assert _keyed(resumed) == _keyed(full)
    lines = (cut_dir / "attempts.jsonl").read_text().splitlines()
    assert len(lines) == len(full) and all(json.loads(line) for line in lines)
    assert _comparable(report.summarize(resumed)) == _comparable(report.summarize(full))
    # a rerun of a finished directory runs nothing and changes nothing
    before = (cut_dir / "attempts.jsonl").read_bytes()
    harness.run(cfg, cut_dir, progress=False, log=lambda m: None).records
    assert (cut_dir / "attempts.jsonl").read_bytes() == before


def test_load_records_rejects_damage_in_the_middle(tmp_path):
    p = tmp_path / "attempts.jsonl"
    good = _rec().to_json()
    p.write_text(good + "\n{broken\n" + good.replace('"context":200000', '"context":200001') + "\n")
    with pytest.raises(harness.DamagedRecords, match="line 2: not valid JSON"):
        harness.load_records(p, 1)


@pytest.mark.slow
def test_kill_9_then_rerun_finishes_identically(tmp_path):
    out = tmp_path / "killed"
    args = [sys.executable, "-m", "benchmarks.run", "--tasks", "launch", "--agents",
            "tests.third_party_agent:SlowRandomAgent", "--contexts", "6", "--attempts", "3", "--seeds", "1",
            "--out", str(out), "--quiet", "--no-plots"]
    env = dict(os.environ, PYTHONPATH=str(REPO))
    proc = subprocess.Popen(args, cwd=REPO, env=env, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE)
    path = out / "attempts.jsonl"
    deadline = time.time() + 60
    while time.time() < deadline and proc.poll() is None:
        if path.exists() and path.read_bytes().count(b"\n") >= 4:
            break
        time.sleep(0.01)
    assert proc.poll() is None, f"run ended before it could be killed: {proc.stderr.read().decode()[-2000:]}"
    os.kill(proc.pid, signal.SIGKILL)
    proc.wait()
    n_before = path.read_bytes().count(b"\n")
    assert 4 <= n_before < 18
    done = subprocess.run(args, cwd=REPO, env=env, capture_output=True, text=True, timeout=120)
    assert done.returncode == 0, done.stderr[-2000:]
    assert "resuming" in done.stderr
    cfg = harness.read_config(out)
    reference = harness.run(cfg, tmp_path / "ref", progress=False, log=lambda m: None).records
    resumed, dropped = harness.load_records(path, 3)
    assert dropped == 0 and _keyed(resumed) == _keyed(reference)
    assert _comparable(report.summarize(resumed)) == _comparable(report.summarize(reference))


def test_a_different_config_is_refused(tmp_path):
    cfg = RunConfig(tasks=["launch"], agents=["random", MY_AGENT], contexts=1, attempts=2, seeds=1)
    harness.run(cfg, tmp_path, progress=False, log=lambda m: None).records
    same_but_reordered = RunConfig(tasks=["launch"], agents=[MY_AGENT, "random"], contexts=1, attempts=2, seeds=1)
    harness.run(same_but_reordered, tmp_path, progress=False, log=lambda m: None).records
    other = dataclasses.replace(cfg, attempts=3)
    with pytest.raises(harness.ConfigMismatch, match=r"attempts: stored 2, now 3.*another --out"):
        harness.run(other, tmp_path, progress=False, log=lambda m: None).records


# ===================================================================================== parallel backends
@pytest.mark.slow
def test_workers_give_the_same_records_as_serial(tmp_path):
    cfg = RunConfig(tasks=["launch", "slide"], agents=["random", MY_AGENT, "tests.third_party_agent:SimAgent",
                                                       "tests.third_party_agent:SetupFailsAgent"],
                    contexts=2, attempts=2, seeds=2)
    serial_run = harness.run(cfg, tmp_path / "serial", progress=False, log=lambda m: None)
    parallel_run = harness.run(cfg, tmp_path / "par", workers=2, progress=False, log=lambda m: None)
    serial, parallel = serial_run.records, parallel_run.records
    assert len(serial) == len(parallel) == 2 * 3 * 2 * 2 * 2
    assert serial_run.unavailable == parallel_run.unavailable and len(serial_run.unavailable) == 4
    assert _keyed(serial) == _keyed(parallel)
    assert _comparable(report.summarize(serial)) == _comparable(report.summarize(parallel))
    assert _comparable(report.summarize(serial)) == _comparable(report.summarize(serial[::-1]))


@pytest.mark.slow
def test_ray_backend_matches_serial(tmp_path):
    pytest.importorskip("ray", reason="Ray is an optional extra (pip install 'phyplan[ray]'); backend not tested")
    cfg = RunConfig(tasks=["launch"], agents=["random", MY_AGENT], contexts=2, attempts=2, seeds=2)
    serial = harness.run(cfg, tmp_path / "serial", progress=False, log=lambda m: None).records
    on_ray = harness.run(cfg, tmp_path / "ray", workers=2, backend="ray", progress=False, log=lambda m: None).records
    assert _keyed(serial) == _keyed(on_ray)


# =============================================================================================== the CLI
def _cli_error(capsys, argv):
    with pytest.raises(SystemExit) as exc:
        run.main(argv)
    assert exc.value.code == 2
    return capsys.readouterr().err


def test_cli_names_errors(tmp_path, capsys):
    err = _cli_error(capsys, ["--tasks", "launch", "lunch", "--out", str(tmp_path)])
    assert "unknown task(s) 'lunch'" in err and "available tasks: launch, slide" in err
    err = _cli_error(capsys, ["--tasks", "launch", "--agents", "randon", "--out", str(tmp_path)])
    assert "unknown agent 'randon'" in err and "random" in err.split("available agents:")[1]
    err = _cli_error(capsys, ["--tasks", "launch", "--agents", "no_such_pkg.mod:Agent", "--out", str(tmp_path)])
    assert "cannot import module 'no_such_pkg.mod'" in err
    err = _cli_error(capsys, ["--tasks", "launch", "--agents", "random", "--contexts", "0", "--out", str(tmp_path)])
    assert "contexts must be a positive integer" in err
    assert not (tmp_path / "config.json").exists()


def test_missing_default_agents_need_skip_missing(monkeypatch):
    monkeypatch.setattr(harness, "DEFAULT_AGENTS", ("random", "not-landed-yet"))
    with pytest.raises(ValueError, match=r"agents not available yet: not-landed-yet .*--skip-missing"):
        harness.resolve_agents(None)
    logs = []
    assert harness.resolve_agents(None, skip_missing=True, log=logs.append) == (["random"], [])
    assert logs == ["skipping agents not available yet: not-landed-yet"]
    with pytest.raises(ValueError, match="unknown agent 'typo'"):      # a non-default name is never skipped
        harness.resolve_agents(["random", "typo"], skip_missing=True)


def test_cli_runs_a_third_party_agent_from_sys_path(tmp_path, capsys, monkeypatch):
    monkeypatch.syspath_prepend(str(REPO / "tests"))     # the "add tests/ to sys.path" route
    out = tmp_path / "cli"
    code = run.main(["--tasks", "launch", "--agents", "third_party_agent:MyAgent", "random", "--contexts", "2",
                     "--attempts", "2", "--seeds", "1", "--out", str(out), "--quiet"])
    assert code == 0
    printed = capsys.readouterr().out
    assert "| launch | third_party_agent:MyAgent | 2 |" in printed and "| launch | random | 2 |" in printed
    for name in ("attempts.jsonl", "config.json", "summary.md", "summary.csv", "regret_launch.png", "runtime.png"):
        assert (out / name).exists(), name
    assert (out / "summary.md").read_text() == printed.rstrip("\n") + "\n"


def test_cli_exit_code_when_an_agent_cannot_be_set_up(tmp_path, capsys):
    argv = ["--tasks", "launch", "--agents", "random", "tests.third_party_agent:SetupFailsAgent", "--contexts", "1",
            "--attempts", "1", "--seeds", "1", "--quiet", "--no-plots"]
    assert run.main(argv + ["--out", str(tmp_path / "a")]) == 1
    err = capsys.readouterr().err
    assert "error: agent 'tests.third_party_agent:SetupFailsAgent' could not be set up on launch" in err
    assert run.main(argv + ["--out", str(tmp_path / "b"), "--skip-missing"]) == 0
    assert "skipped: agent" in capsys.readouterr().err
