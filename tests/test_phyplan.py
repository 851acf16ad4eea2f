"""The PhyPlan agent: skill-chain queries and rollouts, MCTS, GP-UCB, the registered agents.

The planner is tested with closed-form stand-in skill models (exact pendulum, projectile, friction and hit formulas
behind the same ``predict`` interface as the learnt ones), so these tests do not depend on trained weights and can
check the queries against known answers. The shipped weights are exercised by ``benchmarks/phyplan_eval.py``.
"""
from __future__ import annotations

import math

import gymnasium as gym
import numpy as np
import pytest
import torch
from scipy.special import ellipj, ellipk

import phyplan_agents
import phyplan_envs
from phyplan_agents import TaskInfo
from phyplan_agents.phyplan import MCTS, ChainPredictor, PhyPlanAgent, ResidualGP, chain_for, refine
from phyplan_agents.phyplan import queries as q
from phyplan_envs import assets

from benchmarks.harness import evaluate

G, L = assets.GRAVITY, assets.PENDULUM_LENGTH
MU = assets.TABLE_FRICTION


# ------------------------------------------------------------------------------------ closed-form stand-in skills
class _Swing:
    """Exact pendulum: sin(theta/2) = k sn(K - w0 t; k), omega = -2 k w0 cn(.)."""

    def predict(self, x):
        x = np.asarray(x, dtype=np.float64)
        k = np.sin(x[:, 0] / 2)
        w0 = math.sqrt(G / L)
        sn, cn, _, _ = ellipj(ellipk(k * k) - w0 * x[:, 1], k * k)
        theta = 2 * np.arcsin(np.clip(k * sn, -1, 1))
        return torch.tensor(np.stack([theta, -2 * k * w0 * cn], 1), dtype=torch.float32)


class _Hit:
    """Two-body collision with restitution ``e`` (0.2: within ~5% of the tasks' measured launch speeds)."""

    def __init__(self, e: float = 0.2):
        self.e = e

    def predict(self, x):
        m1, m2, v = x[:, 0], x[:, 1], x[:, 2]
        return ((1 + self.e) * m1 / (m1 + m2) * v)[:, None]


class _Throw:
    def predict(self, x):
        vh, vv, t = x[:, 0], x[:, 1], x[:, 2]
        return torch.stack([vh * t, vv * t - G * t * t / 2, vv - G * t], 1)


class _Slide:
    def predict(self, x):
        v0, t = x[:, 0], x[:, 1]
        return torch.stack([v0 * t - MU * G * t * t / 2, v0 - MU * G * t], 1)


class _Bounce:
    def predict(self, x):   # (e, wedge angle, v_ver, v_hor) -> (v_ver, v_hor): reflection off the incline
        e, al, vv, vh = x[:, 0], x[:, 1], x[:, 2], x[:, 3]
        n_h, n_v = torch.sin(al), torch.cos(al)
        vn = vh * n_h + vv * n_v
        return torch.stack([vv - (1 + e) * vn * n_v, vh - (1 + e) * vn * n_h], 1)


class _Glide:
    def predict(self, x):   # (incline angle, v_down0, v_across0, t) -> (s_down, s_across, v_down): frictionless
        a, vd, va, t = x[:, 0], x[:, 1], x[:, 2], x[:, 3]
        g = G * torch.sin(a)
        return torch.stack([vd * t + g * t * t / 2, va * t, vd + g * t], 1)


class StandInSkills:
    """Closed-form stand-ins for the nominal skills (the wide twins are the same closed forms, Paddles' glide a
    frictionless incline); the general and conditioned bounces (which the composer calls for arrivals off the
    downslope plane and for LaunchBounce's impact pair) are the shipped ones."""

    def __init__(self, hit_restitution: float = 0.2):
        from phyplan_agents.skills import load_skill

        self.swing, self.hit, self.throw = _Swing(), _Hit(hit_restitution), _Throw()
        self.swing_wide, self.hit_wide, self.throw_wide = self.swing, self.hit, self.throw
        self.slide, self.bounce, self.glide = _Slide(), _Bounce(), _Glide()
        for name in ("bounce_general", "bounce_cond", "bounce_general_cond"):
            setattr(self, name, load_skill(name))


SKILLS = StandInSkills()
CHAIN_TASKS = list(phyplan_envs.TASKS)


def _env(task, **kw):
    return gym.make(phyplan_envs.env_id(task), with_panda=False, **kw)   # the Panda is visual only: skip its compile


def _agent(name="phyplan", **kw):
    kw.setdefault("skills", SKILLS)
    return phyplan_agents.make(name, **kw)


def _run(agent, task, seeds, attempts, seed=0):
    """Regret after each attempt, and the actions, for contexts reset with ``seeds``: the harness's cell runner on
    the agent object (set up by it with run ``seed``; the Panda is visual only, so the envs skip it)."""
    recs = evaluate(agent, task, seeds, attempts=attempts, seeds=seed, env_kwargs={"with_panda": False})
    return np.array([r.regret for r in recs]).reshape(len(seeds), attempts), np.array([r.action for r in recs])


# ----------------------------------------------------------------------------------------------------- queries
def test_queries_match_closed_form():
    theta = torch.linspace(math.pi / 4, math.pi / 2, 7)
    v = q.swing_bottom_speed(SKILLS.swing, theta, L)
    np.testing.assert_allclose(v.numpy(), assets.bob_speed(theta.numpy()), rtol=1e-4)

    v0 = torch.tensor([0.5, 1.0, 2.0, 3.0])
    ev = q.throw_landing(SKILLS.throw, v0, torch.zeros(4), 0.3)
    t_fall = math.sqrt(2 * 0.3 / G)
    np.testing.assert_allclose(ev.t.numpy(), t_fall, rtol=1e-4)
    np.testing.assert_allclose(ev.y[:, 0].numpy(), v0.numpy() * t_fall, rtol=1e-4)
    assert bool(ev.valid.all())

    np.testing.assert_allclose(q.slide_stop(SKILLS.slide, v0).numpy(), v0.numpy() ** 2 / (2 * MU * G), rtol=1e-4)

    # reaching an edge at 0.25 m: v^2 = v0^2 - 2 mu g s where reached; the stopping point where not
    ev = q.slide_until(SKILLS.slide, v0, 0.25)
    reach = v0.numpy() ** 2 / (2 * MU * G) > 0.25
    np.testing.assert_array_equal(ev.valid.numpy(), reach)
    v_edge = np.sqrt(np.maximum(v0.numpy() ** 2 - 2 * MU * G * 0.25, 0))
    np.testing.assert_allclose(ev.y[reach, 1].numpy(), v_edge[reach], rtol=1e-3)
    np.testing.assert_allclose(ev.y[~reach, 0].numpy(), v0.numpy()[~reach] ** 2 / (2 * MU * G), rtol=1e-3)


def test_query_without_crossing_is_flagged():
    ev = q.throw_landing(SKILLS.throw, torch.tensor([1.0]), torch.tensor([0.0]), 100.0)   # never falls 100 m
    assert not bool(ev.valid[0])
    assert float(ev.t[0]) == pytest.approx(q.THROW_T_MAX)


# -------------------------------------------------------------------------------------------------------- chain
@pytest.mark.parametrize("task", CHAIN_TASKS)
def test_chain_batched_equals_one_at_a_time(task):
    env = _env(task)
    obs, _ = env.reset(seed=5)
    chain = ChainPredictor.for_task(task, SKILLS)
    chain.set_context(obs)
    rng = np.random.default_rng(0)
    lo, hi = env.action_space.low.astype(np.float64), env.action_space.high.astype(np.float64)
    actions = lo + (hi - lo) * rng.random((64, len(lo)))
    batched = chain.final_xy(actions)
    single = np.vstack([chain.final_xy(a[None]) for a in actions])
    assert batched.shape == (64, 2)
    # LaunchBounce, Paddles: an action whose ball meets a wedge's wall or edge, or a paddle's edge, has no prediction
    # (NaN), batched or not
    assert np.all(np.isfinite(batched)) or task in ("launch-bounce", "paddles")
    assert np.isfinite(batched).mean() > 0.5
    np.testing.assert_allclose(batched, single, atol=1e-5)
    assert chain.evaluations == 128
    env.close()


# where the object's flight starts in the state vector: (x index, y index); the first action is its direction
ORIGIN = {"launch": (2, 3), "slide": (2, 3), "bounce": (5, 6), "bridge": (2, 3)}


@pytest.mark.parametrize("task", [t for t in CHAIN_TASKS if t in ORIGIN])
def test_chain_with_exact_skills_predicts_the_simulator(task):
    """With closed-form skills the chain's errors are the stand-in hit's fixed restitution and contact details that
    no skill models (the ball sliding on the incline): within 15% of the distance travelled."""
    env = _env(task)
    obs, info = env.reset(seed=1)
    chain = ChainPredictor.for_task(task, SKILLS)
    chain.set_context(obs)
    lo, hi = env.action_space.low.astype(np.float64), env.action_space.high.astype(np.float64)
    actions = lo + (hi - lo) * np.array([[0.2, 0.4, 0.2], [0.76, 0.9, 0.76]])[:, :len(lo)]
    pred = chain.final_xy(actions)
    ix, iy = ORIGIN[task]
    origin = obs[[ix, iy]]
    for a, p in zip(actions, pred):
        env.reset(options={"context": info["context"]})
        final = env.step(a)[4]["final_pos"][:2]
        dist = np.linalg.norm(final - origin)
        assert np.linalg.norm(p - final) < 0.15 * dist, (a, p, final)
        # the object travels along the first action dimension's direction (hit plane or wedge yaw)
        assert abs(math.remainder(math.atan2(p[1] - origin[1], p[0] - origin[0]) - a[0], 2 * math.pi)) < 1e-4
    env.close()


def test_chain_rejects_bad_state():
    chain = ChainPredictor.for_task("launch", SKILLS)
    with pytest.raises(ValueError, match="finite"):
        chain.set_context([0.3, np.nan, 0, 0, 0.3])
    with pytest.raises(RuntimeError, match="set_context"):
        ChainPredictor.for_task("launch", SKILLS).final_xy(np.zeros((1, 2)))


def test_every_task_has_a_composed_chain():
    for task in phyplan_envs.ALL_TASKS:
        chain = chain_for(task)
        assert chain.task == task and "throw" in chain.skills
        assert chain_for(task) is not None and chain_for(task).rollout.__self__ is chain.rollout.__self__   # cached
    with pytest.raises(ValueError, match="no skill chain.*launch"):
        chain_for("juggle")


def test_chain_needs_the_skills_it_uses():
    class NoBounce:
        throw = SKILLS.throw

    with pytest.raises(ValueError, match="needs skill models bounce"):
        ChainPredictor.for_task("bounce", NoBounce())


# --------------------------------------------------------------------------------------------------------- MCTS
def test_mcts_counts_and_finds_the_peak():
    peak = np.array([0.37, -0.61])

    def f(a):
        return -np.linalg.norm(a - peak, axis=1)

    tree = MCTS(f, [-1, -1], [1, 1], np.random.default_rng(0), n_children=21)
    action, value = tree.run(10)
    # each iteration expands one node (21 children + 1 rollout) or scores one complete action
    assert tree.evaluations <= 10 * 22
    assert tree.root.values is not None and len(tree.root.values) == 21
    assert np.isclose(tree.root.values[0], -1) and np.isclose(tree.root.values[-1], 1)
    assert value == pytest.approx(f(action[None])[0])
    assert value > -0.15                                  # within a grid cell or so of the peak
    best, best_v, n = refine(f, action, value, [-1, -1], [1, 1], width=0.2, points=11, rounds=4)
    assert n == 4 * 121
    assert best_v >= value and best_v > -0.005


def test_mcts_rejects_bad_arguments():
    with pytest.raises(ValueError):
        MCTS(lambda a: a[:, 0], [0, 0], [1], np.random.default_rng(0))
    with pytest.raises(ValueError):
        MCTS(lambda a: a[:, 0], [0], [1], np.random.default_rng(0), n_children=1)


# ----------------------------------------------------------------------------------------------------------- GP
def test_gp_correction_moves_predictions_towards_observations():
    gp = ResidualGP([0, 0], [1, 1], seed=0)
    a = np.array([[0.3, 0.3], [0.7, 0.6], [0.5, 0.9]])
    predicted = np.array([0.95, 0.60, 0.80])
    observed = np.array([0.80, 0.70, 0.81])
    assert np.all(gp.correction(a) == 0)                 # no data: no correction
    for ai, p, o in zip(a, predicted, observed):
        gp.add(ai, o - p)
    mu, sd = gp.predict(a)
    assert np.all(np.abs(predicted + mu - observed) < 0.5 * np.abs(predicted - observed) + 0.01)
    far = gp.predict(np.array([[0.0, 1.0]]))[1]
    assert far[0] > sd.max()                             # less certain away from the data
    with pytest.raises(ValueError):
        gp.add([0.1, 0.1], np.nan)


def test_agent_gp_uses_observed_reward():
    env = _env("launch")
    agent = _agent()
    agent.setup(TaskInfo.from_env(env), seed=0)
    obs, info = env.reset(seed=3)
    agent.begin_context(obs, info)
    a = agent.act()
    before = agent.predicted_reward(a[None])[0]
    observed = before - 0.2                               # pretend the chain was 0.2 too optimistic
    agent.observe(a, observed, {})
    after = agent.score(a[None])[0] - np.sqrt(agent.beta) * agent.gp.predict(a[None])[1][0]
    assert abs(after - observed) < 0.25 * abs(before - observed)
    env.close()


# -------------------------------------------------------------------------------------------------------- agents
def test_registered_variants():
    assert {"phyplan", "phyplan-nogp", "phyplan-sim"} <= set(phyplan_agents.available())
    assert not _agent("phyplan").needs_simulator
    assert not _agent("phyplan-nogp").adapt
    sim = phyplan_agents.make("phyplan-sim")
    assert sim.needs_simulator and type(sim).needs_simulator
    with pytest.raises(ValueError, match="residual"):
        _agent(residual="velocity")


@pytest.mark.parametrize("task", ["launch", "slide"])
def test_actions_in_bounds_and_deterministic(task):
    env = _env(task)
    info = TaskInfo.from_env(env)
    runs = []
    for _ in range(2):
        agent = _agent(iterations=4, refine_rounds=2)
        _, actions = _run(agent, task, seeds=[11, 12], attempts=2, seed=7)
        assert np.all(actions >= info.action_low) and np.all(actions <= info.action_high)
        assert agent.stats()["skill_evals"] > 0 and agent.stats()["sim_calls"] == 0
        runs.append(actions)
    np.testing.assert_array_equal(runs[0], runs[1])
    other = _agent(iterations=4, refine_rounds=0)
    _, actions = _run(other, task, seeds=[11], attempts=1, seed=8)
    assert not np.array_equal(actions[0], runs[0][0])     # another seed explores differently
    env.close()


def test_more_searches_only_while_no_plan_is_a_solution():
    """``searches`` > 1 searches again while the best plan scores below ``search_until`` and keeps the best plan; a
    first plan at or above it ends the decision as the single search does (the same action)."""
    env = _env("launch")
    obs, info = env.reset(seed=5)

    def decide(**kw):
        agent = _agent(iterations=2, refine_rounds=0, **kw)                  # a short search: plans differ
        agent.setup(TaskInfo.from_env(env), seed=0)
        agent.begin_context(obs, info)
        scores = []
        search = agent.search
        agent.search = lambda: scores.append(search()) or scores[-1]
        return agent.act(), agent.last_plan, [s["score"] for s in scores]

    one, plan1, _ = decide()
    again, plan, scores = decide(searches=3, search_until=2.0)           # no plan scores 2: all three searches
    assert plan["searches"] == 3 and len(scores) == 3
    assert plan["score"] == max(scores) and len(set(scores)) > 1         # the later searches explore elsewhere
    np.testing.assert_array_equal(again, np.clip(plan["action"], env.action_space.low, env.action_space.high))
    first, plan, scores = decide(searches=3, search_until=-np.inf)      # the first plan ends it
    assert plan["searches"] == 1 and len(scores) == 1
    np.testing.assert_array_equal(first, one)
    for bad in ({"searches": 0}, {"searches": 1.5}, {"search_until": np.nan}):
        with pytest.raises(ValueError, match=next(iter(bad))):
            _agent(**bad)
    env.close()


def test_image_only_observation_is_a_clear_error():
    env = _env("launch", obs_mode="image", image_size=32)
    with pytest.raises(ValueError, match="state"):
        _agent().setup(TaskInfo.from_env(env), seed=0)
    env.close()


def test_state_image_observation_is_accepted():
    env = _env("launch", obs_mode="state_image", image_size=32)
    agent = _agent(iterations=2, refine_rounds=1)
    agent.setup(TaskInfo.from_env(env), seed=0)
    obs, info = env.reset(seed=0)
    agent.begin_context(obs, info)
    a = agent.act()
    assert a.shape == (2,)
    env.close()


def test_phyplan_beats_random_on_launch():
    """Lenient: on 4 contexts, PhyPlan's mean regret after 2 attempts is below random's and below 0.1."""
    seeds = [101, 102, 103, 104]
    ours, _ = _run(_agent(), "launch", seeds, attempts=2)
    theirs, _ = _run(phyplan_agents.make("random"), "launch", seeds, attempts=2)
    assert ours[:, -1].mean() < theirs[:, -1].mean()
    assert ours[:, -1].mean() < 0.1


def test_position_residual_corrects_a_biased_chain():
    """Slide with a biased hit (restitution 0.4: the puck ~17% too fast): the position GP removes most of the bias
    after one attempt."""
    agent = _agent(residual="position", skills=StandInSkills(hit_restitution=0.4))
    regrets, _ = _run(agent, "slide", seeds=[201, 202], attempts=2)
    assert np.all(regrets[:, 1] < 0.5 * regrets[:, 0] + 0.01)


def test_phyplan_sim_counts_simulator_calls():
    env = _env("launch")
    agent = phyplan_agents.make("phyplan-sim", iterations=2, discretisation=4, refine_rounds=1, refine_points=3)
    agent.setup(TaskInfo.from_env(env), seed=0)
    with pytest.raises(ValueError, match="Simulator"):
        obs, info = env.reset(seed=1)
        agent.begin_context(obs, info, None)
    env.close()
    regrets, _ = _run(agent, "launch", seeds=[1], attempts=1)
    stats = agent.stats()
    # 2 MCTS iterations with 5 children (+1 rollout each, or 1 complete action) and one 3x3 refinement round
    assert 0 < stats["sim_calls"] <= 2 * 6 + 9
    assert stats["skill_evals"] == 0


# ------------------------------------------------------------------------------------------------ fast inference
def test_fast_twin_matches_the_skill_network():
    from phyplan_agents.phyplan.fastnet import FastSkill, fast_twin
    from phyplan_agents.skills import SkillModel

    torch.manual_seed(0)
    model = SkillModel("throw", "pinn", in_center=[3.0, 0.0, 0.5], in_scale=[3.0, 3.0, 0.5],
                       out_mean=[1.0, -0.5, 0.0], out_scale=[2.0, 1.5, 4.0])
    twin = fast_twin(model)
    assert isinstance(twin, FastSkill) and twin.spec is model.spec
    x = torch.tensor([[1.0, 0.5, 0.2], [5.5, -2.0, 0.9], [0.0, 0.0, 0.0]])
    np.testing.assert_allclose(twin.predict(x).numpy(), model.predict(x).numpy(), rtol=1e-5, atol=1e-5)
    assert fast_twin(SKILLS.throw) is SKILLS.throw            # not a skill network: used as it is


# ------------------------------------------------------------------------------------------- shipped skill models
@pytest.mark.parametrize("task", ["launch", "bounce"])
def test_registered_agent_uses_the_shipped_skills(task):
    """``make("phyplan")`` loads the shipped skill weights; its chain predicts the simulator within 3 cm here
    (benchmarks/phyplan_eval.py measures means of 4-15 mm)."""
    env = _env(task)
    agent = phyplan_agents.make("phyplan")
    agent.setup(TaskInfo.from_env(env), seed=0)
    assert type(agent.predictor.skills.swing).__name__ == "FastSkill"     # the shipped networks, fast path
    obs, info = env.reset(seed=100001)
    agent.begin_context(obs, info)
    lo, hi = env.action_space.low.astype(np.float64), env.action_space.high.astype(np.float64)
    actions = lo + (hi - lo) * np.array([[0.3, 0.3], [0.7, 0.8]])
    for a, p in zip(actions, agent.predictor.final_xy(actions)):
        env.reset(options={"context": info["context"]})
        assert np.linalg.norm(env.step(a)[4]["final_pos"][:2] - p) < 0.03
    with pytest.raises(ValueError, match="skill_kinds"):
        phyplan_agents.make("phyplan", skills=SKILLS, skill_kinds={"swing": "nn"})
    env.close()
