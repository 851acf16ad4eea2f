"""The design checks' seed arguments (benchmarks/design_checks/seeds.py): fresh seeds outside every split, and bad
seeds or counts refused with an error naming the argument."""
from __future__ import annotations

import numpy as np
import pytest

from benchmarks.design_checks import seeds as seeding
from phyplan_envs.splits import split_of


def test_fresh_seeds_lie_outside_every_split():
    fresh = seeding.seed_list(seeding.FRESH_SEED, seeding.FRESH_STEP, 1000)
    assert fresh[:2] == [7_310_000, 7_317_919] and len(set(fresh)) == 1000
    assert all(split_of(s) is None for s in fresh)
    assert seeding.describe(fresh) == "seeds 7310000 + 7919 i, i < 1000, outside every split"
    assert seeding.describe(list(range(20))) == "seeds 0..19, in the train split"
    assert seeding.describe([200_000, 7_310_000]) == "seeds 200000 + 7110000 i, i < 2, in no split and the test split"


def test_seed_list_refuses_bad_values():
    for bad in ((-1, 1, 3), (0, 0, 3), (0, 1, 0)):
        with pytest.raises(ValueError):
            seeding.seed_list(*bad)


def _cli_error(main, argv, capsys) -> str:
    with pytest.raises(SystemExit) as exc:
        main(argv)
    assert exc.value.code == 2
    return capsys.readouterr().err


@pytest.mark.parametrize("module, argv, named", [
    ("hidden_physics", ["--n", "0"], "--n"),
    ("hidden_physics", ["--seed", "-1"], "--seed"),
    ("hidden_physics", ["--seed-step", "0"], "--seed-step"),
    ("hidden_physics", ["--seed", str(2 ** 32 - 5), "--n", "10"], "2**32"),
    ("chaos", ["--actions", "0"], "--actions"),
    ("chaos", ["--seed", "-7"], "--seed"),
    ("chaos", ["--ids", "PhyPlan/LaunchVaried-v0"], "--ids"),
    ("bridge", ["--chaos", "--seed-step", "-2"], "--seed-step"),
    ("bridge", ["--chaos", "--actions", "-1"], "--actions"),
    ("bounce", ["--seed", "-1"], "--seed"),
    ("bounce", ["--time", "-3"], "--time"),
    ("paddles", ["--solvable", "2", "--starts", "0"], "--starts"),
    ("paddles", ["--reach", "2", "--depths", "0"], "--depths"),
    ("paddles", ["--chaos", "2", "--halvings", "-1"], "--halvings"),
    ("paddles", ["--reach", "2", "--halvings", "1"], "--halvings"),
    ("paddles", ["--reach", "2", "--paddle-size", "0"], "--paddle-size"),
    ("paddles", ["--reach", "2", "--paddle-size", "nan"], "--paddle-size"),
    ("paddles", ["--reach", "2", "--paddle-tilt", "90"], "--paddle-tilt"),
    ("paddles", ["--reach", "2", "--chain-only"], "--chain-only"),
    ("paddles", ["--solvable", "2", "--relative"], "--relative"),
    ("paddles", ["--solvable", "2", "--move-alone", "--version", "0"], "--move-alone needs"),
    ("paddles", ["--solvable", "2", "--move-alone", "--chain-only", "--relative", "--version", "0"],
     "--move-alone needs"),
    ("paddles", ["--reach", "2", "--move-alone"], "--move-alone needs"),
    ("paddles", ["--reach", "2", "--physics-space", "train"], "--physics-space"),
    ("paddles", ["--reach", "2", "--per-context"], "--per-context"),
    ("paddles", ["--chaos", "2", "--physics-space", "train", "--paddle-tilt", "30"], "--physics-space"),
    ("paddles", ["--chaos", "2", "--physics-space", "train", "--paddle-restitution", "0.8"], "--physics-space"),
    ("paddles", ["--chaos", "2", "--paddle-restitution", "1.0"], "--paddle-restitution"),
    ("paddles", ["--episode-cost", "-1"], "--episode-cost"),
    ("paddles", ["--chaos", "2", "--paddle-restitution", "nan"], "--paddle-restitution"),
    ("paddles", ["--chaos", "2", "--timestep", "0.01"], "--timestep"),
    ("paddles", ["--chaos", "2", "--offset-span", "2.0", "1.0"], "--offset-span"),
    ("paddles", ["--chaos", "2", "--offset-span", "0.5", "2.0", "--version", "0"], "--offset-span"),
    ("paddles", ["--chaos", "2", "--offset-span", "0.5", "6.5"], "--offset-span"),
    ("paddles_bypass", ["--depths", "1"], "--depths"),
    ("paddles_bypass", ["--actions", "0"], "--actions"),
    ("paddles_bypass", ["--nearest", "0"], "--nearest"),
    ("paddles_bypass", ["--relative", "5", "--offsets", "0.9", "0.4"], "--offsets"),
    ("paddles_bypass", ["--relative", "-1"], "--relative"),
    ("launch_bounce", ["--chaos", "--reach-restitutions", "0.5"], "--reach-restitutions needs --reach"),
    ("launch_bounce", ["--reach", "2", "--reach-restitutions", "1.5"], "--reach-restitutions"),
    ("launch_bounce", ["--pedestal", "0", "--chaos", "--actions", "-1"], "--actions"),
    ("launch_bounce", ["--pedestal", "-3"], "--pedestal"),
    ("launch_bounce", ["--reach", "2", "--varied"], "--varied"),
])
def test_bad_seed_arguments_are_refused_by_name(module, argv, named, capsys):
    import importlib

    main = importlib.import_module(f"benchmarks.design_checks.{module}").main
    err = _cli_error(main, argv, capsys)
    assert named in err and "error" in err


def test_solvability_refuses_bad_seeds(capsys):
    from benchmarks import solvability

    for argv, named in ((["--seed-step", "0"], "--seed-step"), (["--first-seed", "-4"], "--first-seed"),
                        (["--contexts", "0"], "--contexts"), (["--restarts", "0"], "--restarts")):
        assert named in _cli_error(solvability.main, argv, capsys)


def test_solvability_restarts_search_again_with_the_next_oracle_seed():
    """A context the first search leaves unsolved is searched again with oracle seed + 1, and the row keeps the
    better of the two replayed rewards; a solved context is not searched again."""
    from benchmarks import solvability

    def row(oracle_seed, restarts, budget=4):
        return solvability.certify_context(("slide", 3, budget, oracle_seed, 0.995, 1, "auto", restarts))

    # 4 simulator calls leave Slide's context 3 unsolved (checked, not assumed: an early solve fails the test)
    first, second = row(0, 1), row(1, 1)
    assert not first["solved"] and first["searches"] == 1
    both = row(0, 2)
    assert both["searches"] == 2 and both["sim_calls"] == first["sim_calls"] + second["sim_calls"]
    assert both["best_reward"] == max(first["best_reward"], second["best_reward"])
    assert both["best_search"] == int(second["best_reward"] > first["best_reward"])
    solved = row(0, 3, budget=200)
    assert solved["solved"] and solved["searches"] == solved["best_search"] + 1


def test_chaos_runs_on_the_given_contexts():
    """final_positions resets to the context seeds it is given (default 0 .. n-1, as robot_check), each action once."""
    from benchmarks.design_checks.chaos import final_positions, random_actions
    from phyplan_envs.tasks.launch import LaunchEnv

    class Recording(LaunchEnv):
        def reset(self, *, seed=None, options=None):
            self.seeds.append(seed)
            return super().reset(seed=seed, options=options)

    env = Recording(with_panda=False)
    env.seeds = []
    acts = random_actions(env, 2, 0)
    fresh = final_positions(env, acts, context_seeds=[7_310_000, 7_317_919])
    assert env.seeds == [7_310_000, 7_317_919]
    env.reset(seed=7_317_919)
    assert np.array_equal(env.step(acts[1])[4]["final_pos"], fresh[1])
    env.seeds = []
    final_positions(env, acts)
    assert env.seeds == [0, 1]
    with pytest.raises(ValueError, match="context seeds"):
        final_positions(env, acts, context_seeds=[1])
    env.close()


@pytest.fixture
def paddle_shifts(monkeypatch):
    """``paddle_matters`` on a fake two-placed-paddle env (x in [-1, 1]; its faces falling as Paddles-3's) whose every
    attempt scores 0.5: returns ``run(action, relative, alone)`` -> (the check's rewards, the (paddle 1, paddle 2)
    action values of every action it tried)."""
    from types import SimpleNamespace

    from benchmarks.design_checks import paddles_solver as paddles

    tried = []

    def fake_attempt(env, context, action):
        tried.append(np.array(action))
        return 0.5, 0.0, []

    monkeypatch.setattr(paddles, "attempt", fake_attempt)
    env = SimpleNamespace(action_low=np.array([0.2, -1.0, -1.0]), action_high=np.array([0.5, 1.0, 1.0]),
                          facts=SimpleNamespace(paddle_falls=(1, -1, 1)))

    def run(action, relative=False, alone=False):
        tried.clear()
        out = (paddles.paddle_matters(env, None, np.array(action), relative, alone=True) if alone
               else paddles.paddle_matters(env, None, np.array(action), relative))
        return out, [(round(float(a[1]), 6), round(float(a[2]), 6)) for a in tried]
    return run


def test_paddle_shift_counts_only_whole_moves(paddle_shifts):
    """Every paddle matters: a move the action bound cuts short is not a 0.2 m move, so only whole moves are tried."""
    out, moved = paddle_shifts([0.3, 0.9, 0.0])
    assert out == [0.5, 0.5]
    assert moved == [(0.7, 0.0), (0.9, -0.2), (0.9, 0.2)]     # paddle 1's +0.2 (to 1.1) is not tried


def test_a_relative_shift_moves_the_paddle_and_every_paddle_below_it(paddle_shifts):
    """Relative placement: moving paddle 1's offset moves paddles 1 and 2 together, so a move that takes paddle 2 out
    of bounds is not tried, and a paddle whose moves all leave the bounds gives NaN."""
    from types import SimpleNamespace

    from benchmarks.design_checks import paddles_solver as paddles

    out, moved = paddle_shifts([0.3, 0.0, 0.9], relative=True)
    assert out == [0.5, 0.5] and moved == [(-0.2, 0.7), (0.0, 0.7)]     # +0.2 would put paddle 2 at 1.1
    narrow = SimpleNamespace(action_low=np.array([0.2, -0.1, -0.1]), action_high=np.array([0.5, 0.1, 0.1]))
    assert np.isnan(paddles.paddle_matters(narrow, None, np.array([0.3, 0.0, 0.0]), relative=True)).all()


def test_a_paddle_moved_alone_keeps_every_other_paddle_where_it_is(monkeypatch):
    """``alone`` on Paddles-v2 (N = 4): each tried action changes only offsets d and d + 1 (d alone for the last
    paddle), and puts paddle d +-0.2 m from where it was with every other paddle's x unchanged. In x differences the
    two change by opposite amounts; but the faces fall alternately and each offset is measured along the way its
    upper paddle's face falls, so both offsets move by the same s. A move that kept offset d + 1 fixed, or moved it
    by -s, would move paddle d + 1 as well (by 0.2 or 0.4 m)."""
    from benchmarks.design_checks import paddles_solver as paddles
    from benchmarks.design_checks.paddles_actions import TASK

    env = TASK.make(4, record_trajectory=True)
    tried = []
    monkeypatch.setattr(paddles, "attempt", lambda env, context, a: tried.append(np.array(a)) or (0.5, 0.0, []))
    action = (env.action_low + env.action_high) / 2
    assert paddles.paddle_matters(env, None, action, alone=True) == [0.5, 0.5, 0.5]
    assert len(tried) == 6                                  # both sides of each of the 3 placed paddles fit
    x0 = env.paddle_x(action)[0]
    for i, b in enumerate(tried):
        d = i // 2 + 1
        changed = np.flatnonzero(~np.isclose(b, action))
        assert changed.tolist() == ([d, d + 1] if d < 3 else [d])
        moved = env.paddle_x(b)[0] - x0
        assert np.isclose(abs(moved[d]), 0.2) and np.allclose(np.delete(moved, d), 0.0)
    # the default check still moves one action value: paddle d and every paddle below it
    tried.clear()
    paddles.paddle_matters(env, None, action)
    assert [np.flatnonzero(~np.isclose(b, action)).tolist() for b in tried] == [[1], [1], [2], [2], [3], [3]]


def test_a_paddle_moved_alone_counts_only_moves_inside_the_bounds(paddle_shifts):
    """Moving paddle d alone changes offsets d and d + 1: a side that takes either out of its bounds is not tried,
    and a paddle with no side that fits gives NaN, which never matters."""
    from types import SimpleNamespace

    from benchmarks.design_checks import paddles_solver as paddles

    out, moved = paddle_shifts([0.3, 0.0, 0.0], alone=True)
    assert out == [0.5, 0.5] and moved == [(-0.2, -0.2), (0.2, 0.2), (0.0, -0.2), (0.0, 0.2)]
    out, moved = paddle_shifts([0.3, 0.0, 0.9], alone=True)          # +0.2 on paddle 1 puts offset 2 at 1.1
    assert out == [0.5, 0.5] and moved == [(-0.2, 0.7), (0.0, 0.7)]
    out, moved = paddle_shifts([0.3, 0.9, 0.0], alone=True)          # +0.2 on paddle 1 puts offset 1 at 1.1
    assert moved == [(0.7, -0.2), (0.9, -0.2), (0.9, 0.2)]
    narrow = SimpleNamespace(action_low=np.array([0.2, -0.3, -0.1]), action_high=np.array([0.5, 0.3, 0.1]),
                             facts=SimpleNamespace(paddle_falls=(1, -1, 1)))
    out = paddles.paddle_matters(narrow, None, np.array([0.3, 0.0, 0.0]), alone=True)
    assert np.isnan(out).all()                   # offset 2 (paddle 1's neighbour, and paddle 2's own) cannot move
    assert not bool(np.all(np.array(out) < paddles.MATTERS))


def test_paddle_chaos_reports_which_moved_landings_met_other_paddles(monkeypatch):
    """The chaos check flags a moved landing whose ball met another set of paddles (a graze of an edge) apart from
    one that met the same paddles: here the fake simulator lands every moved action 5 cm off, and half of them miss
    the last paddle."""
    from benchmarks.design_checks import paddles_landings as paddles

    acts = [np.array([0.3, 0.5 + 0.1 * i]) for i in range(4)]        # inside v1's offset bounds
    monkeypatch.setattr(paddles, "chain_actions", lambda env, context, k, rng, aimed=False: acts[:k])

    def fake_attempt(env, context, action):
        base = any(np.array_equal(action, a) for a in acts)
        i = int(round(float(action[1] - 0.5) * 10))
        return 1.0, 0.0 if base else 0.05, [True, True] if base or i % 2 else [True, False]

    monkeypatch.setattr(paddles, "attempt", fake_attempt)
    c = paddles.chaos(2, 4, seed=1, deltas=[1e-8])
    assert c["actions"] == 4
    assert np.allclose(c["moves"][1e-8], 0.05)
    assert c["other_paddles"][1e-8].tolist() == [True, False, True, False]


def test_varied_reach_runs_under_the_given_restitution():
    """The varied reach measures under the physics it is given: a restitution changes the landings."""
    from benchmarks.design_checks.launch_bounce import reach

    low, high = reach(40, 0, {"bob_mass": 0.5, "restitution": 0.5, "wedge_restitution": 0.4}), \
        reach(40, 0, {"bob_mass": 0.5, "restitution": 0.5, "wedge_restitution": 0.99})
    assert len(low) and len(high)
    assert not np.array_equal(low[:min(len(low), len(high))], high[:min(len(low), len(high))])


def test_a_ball_that_comes_back_to_the_pedestal_is_seen_in_its_trajectory():
    """``comes_back``: a flight that leaves the pedestal and returns to its column below the top counts; one that
    passes over the top, or never leaves, does not. On the simulator: the ball sent along +x onto the wedge's
    vertical back wall 0.35 m out bounces back into the column (it rests 4 cm out); with the wedge at the far end of
    its range, off the flight's path, it lands 0.4 m out and does not come back."""
    from types import SimpleNamespace

    from benchmarks.design_checks.launch_bounce import comes_back
    from phyplan_envs.tasks.launch_bounce import LaunchBounceEnv

    facts = SimpleNamespace(pedestal_xy=(0.0, 0.0), pedestal_height=0.313, ball_radius=0.02)
    out = np.linspace(0.0, 0.5, 20)
    t = np.arange(40)[:, None] * 0.01
    there_and_back = np.column_stack([np.r_[out, out[::-1]], np.zeros(40), np.full(40, 0.2)])
    assert comes_back(facts, np.hstack([t, there_and_back]))
    over = there_and_back.copy()
    over[:, 2] = 0.35                                        # back above the column's top (0.313 + 0.02)
    assert not comes_back(facts, np.hstack([t, over]))
    near = there_and_back.copy()
    near[:, 0] = np.minimum(near[:, 0], 0.1)                 # never farther than 0.1 m: it never left
    assert not comes_back(facts, np.hstack([t, near]))
    env = LaunchBounceEnv(with_panda=False)
    for action, back in (([0.0, 1.0, 0.35, 0.0, 0.0], True), ([0.3, 1.0, 1.0, np.pi / 2, 0.0], False)):
        env.reset(seed=0, options={"record_trajectory": True})
        assert comes_back(env.facts, env.step(np.array(action))[4]["trajectory"]) is back
    env.close()


def test_p90_interval_holds_the_sample_p90_and_narrows_with_more_actions():
    from benchmarks.design_checks.launch_bounce import p90_interval

    rng = np.random.default_rng(3)
    small, large = rng.exponential(1.0, 200), rng.exponential(1.0, 5000)
    lo, hi = p90_interval(small)
    assert lo <= np.percentile(small, 90) <= hi
    lo_l, hi_l = p90_interval(large)
    assert lo_l <= np.log(10) <= hi_l                     # the exponential's true p90
    assert hi_l - lo_l < (hi - lo) / 2                    # 25x the actions: about a fifth of the width


@pytest.mark.parametrize("module, argv, named", [
    ("benchmarks.design_checks.launch_bounce", ["--chaos", "--halvings", "0"], "--halvings"),
    ("benchmarks.design_checks.launch_bounce", ["--chaos", "--version", "2"], "--version"),
    ("benchmarks.design_checks.paddles", ["--solvable", "1", "--goal-range", "0.9", "0.8"], "--goal-range"),
    ("benchmarks.design_checks.paddles", ["--chaos", "1", "--goal-range", "0.8", "0.9"], "--goal-range"),
    ("benchmarks.design_checks.paddles", ["--chain", "-1"], "--chain"),
    ("benchmarks.design_checks.paddles", ["--reach", "-2"], "--reach"),
])
def test_bad_study_arguments_are_refused_by_name(module, argv, named, capsys):
    import importlib

    with pytest.raises(SystemExit):
        importlib.import_module(module).main(argv)
    assert named in capsys.readouterr().err


def test_a_given_goal_range_places_the_goals(monkeypatch):
    import benchmarks.design_checks.paddles as P
    import benchmarks.design_checks.paddles_solver as S

    goals = []

    def solve(env, context, rng, starts=3, chain_only=False, aimed=False):   # record each context's goal; no search
        goals.append(np.array(context["goal"]))
        return 0.5, env.action_low.copy(), 1
    monkeypatch.setattr(S, "solve", solve)
    S.solvable(2, 4, P.TEST_SEED, P.TEST_STEP, goal_range=(0.6, 0.65))
    assert len(goals) == 4 and all(0.6 <= g[0] <= 0.65 and g[1] == 0.0 for g in goals)
    assert len({float(g[0]) for g in goals}) == 4


def test_paddles_chaos_share_interval_and_finer_timestep():
    """The moved-landings share's 95% interval holds the share and narrows with more landings; ``finer`` halves the
    task's timestep and keeps its end rule every 5 ms."""
    from benchmarks.design_checks.paddles_landings import finer, share_interval

    lo, hi = share_interval(4, 200)
    assert lo < 0.02 < hi and lo > 0
    lo2, hi2 = share_interval(16, 800)
    assert hi2 - lo2 < hi - lo
    assert share_interval(0, 200)[0] == 0.0
    base, fine = finer(2, 0), finer(2, 2)
    assert fine.timestep == base.timestep / 4 and fine.timestep * fine.chunk == base.timestep * base.chunk


def test_paddles_size_study_builds_that_size_and_keeps_the_task():
    """``--paddle-size``'s task has boards and described faces of that edge; the default is the registered task."""
    import gymnasium as gym

    from benchmarks.design_checks.paddles_actions import make

    small, task = make(2, 0.3), make(2)
    assert type(task) is type(gym.make("PhyPlan/Paddles-v2").unwrapped) and task.facts.paddle_half == 0.25
    for env, half in ((small, 0.15), (task, 0.25)):
        env.reset(seed=0)
        face = env.describe(np.array([0.3, 0.0])).faces[1]
        edges = np.linalg.norm(np.diff(face.vertices[0], axis=0), axis=1)
        assert np.allclose(edges, 2 * half)
        assert np.allclose(env.scene.model.geom("paddle1_board").size[:2], half)


def test_a_bouncing_paddles_study_builds_its_contact_timestep_and_offsets():
    """``--paddle-restitution``, ``--timestep``, ``--offset-span``: the study's task has a soft contact of that
    restitution, that timestep (the end rule still every 5 ms) and those offset bounds; its ball bounces off paddle 0
    and lands farther out than on the task, whose paddle keeps none of the normal speed (1.41 m at N = 1: the
    goal range); the default design is the registered task."""
    import math

    from benchmarks.design_checks.paddles_actions import TASK, Design
    from phyplan_envs.contact import restitution_of_solref

    study = Design(restitution=0.8, timestep=6.25e-5, offset_span=(0.5, 3.0))
    assert TASK.is_task() and Design(version=0).is_task() and not study.is_task()
    env = study.make(2)
    assert math.isclose(restitution_of_solref(env.scene.model.geom("paddle0_board").solref), 0.8, rel_tol=1e-9)
    assert env.timestep == 6.25e-5 and math.isclose(env.timestep * env.chunk, 0.005)
    assert env.action_low[1] == 0.5 and env.action_high[1] == 3.0
    landings = []
    for design in (study, TASK):
        one = design.make(1)
        one.reset(seed=0)
        landings.append(one.step(np.array([0.35]))[4]["final_pos"][0])
    assert 1.40 <= landings[1] <= 1.42 and landings[0] > landings[1] + 0.3
    with pytest.raises(ValueError, match="physics_space"):
        study.make(2, physics_space="train")


def test_episode_cost_times_the_design_and_the_task(capsys):
    """``--episode-cost K`` prints, per N, the CPU time per episode of the checked design and of the task."""
    from benchmarks.design_checks.paddles import main

    assert main(["--episode-cost", "1", "--depths", "1", "--timestep", "2.5e-4"]) == 0
    out = capsys.readouterr().out
    assert out.startswith("N=1 episode cost over 1 random actions: ") and "the task" in out and "x)" in out


def test_chain_check_composes_on_the_study_design(capsys):
    """``--chain K`` composes the chain from the checked design's scene: on bouncing paddles (restitution 0.8) at
    N = 1 the unchanged skills land within centimetres of the simulator (0.4-1.0 cm at 0.0156 ms in docs/depth.md;
    here a 0.0625 ms step, which moves the landing by under 1 cm at N = 1), with a prediction for every action."""
    import re

    from benchmarks.design_checks.paddles import main

    assert main(["--chain", "3", "--depths", "1", "--paddle-restitution", "0.8", "--timestep", "6.25e-5"]) == 0
    out = capsys.readouterr().out
    m = re.search(r"N=1 chain over 3 chain actions: landing error mean ([\d.]+) cm, p90 ([\d.]+) cm, no prediction "
                  r"for 0%", out)
    assert m and float(m.group(2)) < 3.0, out


def test_paddles_tilt_study_tilts_the_boards_and_their_faces():
    """``--paddle-tilt``'s task tilts every board and its described face by that angle; the size stays the task's."""
    import math

    from benchmarks.design_checks.paddles_actions import make

    env = make(3, tilt=30.0)
    env.reset(seed=0)
    assert env.facts.paddle_tilt == math.radians(30.0) and env.facts.paddle_half == 0.25
    for face, falls in zip(env.describe(np.array([0.3, 0.0, 0.0])).faces, env.facts.paddle_falls):
        assert np.allclose(face.normal[0], [falls * 0.5, 0.0, math.sqrt(3) / 2])
    q = env.scene.model.body("paddle1").quat
    assert math.isclose(2 * math.degrees(math.acos(abs(q[0]))), 30.0, abs_tol=1e-9)


def test_the_chain_only_solver_keeps_the_ball_on_every_paddle(monkeypatch):
    """Here the fake simulator scores a larger paddle-1 x higher, but the ball misses paddle 1 from x = 0.05 on: the
    plain solver climbs past 0.3, the chain-only one stays below it, and both start from the same chain action."""
    from types import SimpleNamespace

    import benchmarks.design_checks.paddles_solver as P

    env = SimpleNamespace(action_low=np.array([0.2, -1.0]), action_high=np.array([0.5, 1.0]))
    monkeypatch.setattr(P, "chain_actions", lambda env, context, k, rng, aimed=False: [np.array([0.3, 0.0])])
    monkeypatch.setattr(P, "attempt", lambda env, context, a: (float(a[1]), 0.0, [True, bool(a[1] < 0.05)]))
    rng = np.random.default_rng(0)
    _, plain, _ = P.solve(env, None, rng, starts=1)
    _, chained, _ = P.solve(env, None, rng, starts=1, chain_only=True)
    assert plain[1] > 0.15 and 0.03 < chained[1] < 0.05


def test_bypass_proof_goals_keep_a_tenth_of_their_distance_from_every_partial_landing():
    from benchmarks.design_checks.paddles_bypass import bypass_proof

    stretches = bypass_proof(np.array([0.5, 1.0]), lo=0.2, hi=1.2, nearest=0.3)
    # 0.5 spoils x within 0.1 x of it (0.455 < x < 0.556), 1.0 spoils 0.91 < x < 1.12
    assert [(round(a, 2), round(b, 2)) for a, b in stretches] == [(0.3, 0.45), (0.56, 0.9), (1.12, 1.2)]
    assert np.allclose(bypass_proof(np.empty(0), 0.2, 0.5, 0.1), [(0.2, 0.5)])
    assert bypass_proof(np.linspace(0.0, 2.0, 201), 0.2, 1.5, 0.1) == []


def test_a_touch_of_a_paddle_edge_counts_as_touching_its_board_not_as_meeting_its_face():
    """A vertical flight sampled every 5 cm (as at 10 m/s every 5 ms) passes paddle 0's lower edge 2 mm inside the
    ball's radius, its samples 2.5 cm above and below the edge: the board test sees the touch between the samples,
    the face test does not; 1 cm outside the radius, neither does."""
    from benchmarks.design_checks.paddles_actions import make, met_paddles

    env = make(1)
    env.reset(seed=0)
    a = np.array([0.3])
    face = env.describe(a).faces[0]
    n, c = face.normal[0], face.vertices[0].mean(axis=0)
    down = np.cross(n, (0.0, 1.0, 0.0))
    edge = min(c + env.facts.paddle_half * down, c - env.facts.paddle_half * down, key=lambda e: e[2])
    out = np.sign(edge[0] - c[0])
    r = env.facts.ball_radius
    for clearance, touched in ((-0.002, True), (0.01, False)):
        z = edge[2] + 0.025 + 0.05 * np.arange(6)[::-1] - 0.25
        path = np.column_stack([np.full(6, edge[0] + out * (r + clearance)), np.zeros(6), z])
        traj = np.column_stack([np.arange(6) * 0.005, path])
        assert met_paddles(env, a, traj, board=True) == [touched]
        assert met_paddles(env, a, traj) == [False]
        assert met_paddles(env, a, traj, between=True) == [False]


def test_a_bounce_between_two_samples_meets_the_face_only_on_the_free_flight_between_them():
    """A ball 32 mm and 12 mm from touching paddle 0's face at the centre, closing at 4 m/s, then 8 mm and 28 mm
    away: it bounced in between. No sample is within 4 mm (the task's test at the samples misses it); the free
    flight from the 12 mm sample reaches the face 3 ms later (the test between the samples meets it). The default
    follows the paddles: the task's keep to the samples, a bouncing study's look between them."""
    from benchmarks.design_checks.paddles_actions import Design, make, met_paddles

    for env, default in ((make(1), [False]), (Design(restitution=0.8).make(1), [True])):
        env.reset(seed=0)
        a = np.array([0.3])
        face = env.describe(a).faces[0]
        n, c = face.normal[0], face.vertices[0].mean(axis=0)
        gaps = np.array([0.052, 0.032, 0.012, 0.008, 0.028])
        path = c + (env.facts.ball_radius + gaps)[:, None] * n
        traj = np.column_stack([np.arange(5) * 0.005, path])
        assert met_paddles(env, a, traj, between=False) == [False]
        assert met_paddles(env, a, traj, between=True) == [True]
        assert met_paddles(env, a, traj) == default
        # the same flight 2 cm off the face: it bounced off something else, the free flight does not reach the face
        assert met_paddles(env, a, traj + np.r_[0.0, 0.02 * n][None, :], between=True) == [False]


def test_face_tests_count_the_paddles_each_test_meets():
    """At N = 1 every ball meets the fixed paddle 0 by both tests; on a bouncing design's N = 2 the test between the
    samples meets every paddle the test at the samples meets (it looks at the samples too), and paddle 0 on every
    action."""
    import benchmarks.design_checks.paddles as P
    from benchmarks.design_checks.paddles_actions import TASK, Design, face_tests

    f = face_tests(1, 3, seed=0, design=TASK)
    assert f["samples"].tolist() == f["between"].tolist() == [3] and f["differ"] == 0
    f = face_tests(2, 2, seed=0, design=Design(restitution=0.8, offset_span=(0.5, 3.0)))
    assert np.all(f["between"] >= f["samples"]) and f["between"][0] == 2
    with pytest.raises(SystemExit):
        P.main(["--face-at-samples", "--reach", "1"])


def test_reach_measures_each_paddles_offset_along_the_balls_way(monkeypatch):
    """At N = 3 paddle 0 (x = 0.25) throws the ball towards +x and paddle 1 towards -x: on v0 paddles at 0.85 and
    0.35 are 0.6 and 0.5 m along the ball's way; an episode that ends with the ball in the air is counted."""
    import benchmarks.design_checks.paddles_landings as P
    from benchmarks.design_checks.paddles import TEST_SEED

    acts = [np.array([0.3, 0.85, 0.35]), np.array([0.4, 0.65, 0.05])]
    monkeypatch.setattr(P, "chain_actions", lambda env, context, k, rng, aimed=False: acts[:k])
    monkeypatch.setattr(P, "flight", lambda env, context, a: (0.0, {"final_pos": np.array([a[2], 0.0, 0.0]),
                                                                  "end_reason": "landed" if a[2] > 0.1 else "timeout"}))
    landings, offsets, airborne = P.reach(3, 2, TEST_SEED, P.Design(version=0))
    assert landings.tolist() == [0.35, 0.05] and airborne == 1
    assert np.allclose(offsets, [[0.6, 0.5], [0.4, 0.6]])
    _, offsets, _ = P.reach(3, 2, TEST_SEED)               # v1's actions are the offsets
    assert np.allclose(offsets, [a[1:] for a in acts])


def test_relative_draws_at_n2_put_paddle_1_under_the_ball():
    """N = 2: paddle 1 placed 0.45-0.9 m from paddle 0 along the ball's way always fits the bounds and catches the
    ball (all of 200 such draws did); a paddle 1.5-2 m away never fits."""
    from benchmarks.design_checks.paddles import TEST_SEED
    from benchmarks.design_checks.paddles_bypass import relative_share

    assert relative_share(2, 6, TEST_SEED, (0.45, 0.9)) == (6, 6)
    assert relative_share(2, 6, TEST_SEED, (1.5, 2.0)) == (0, 0)


def test_paddles_chaos_on_the_varied_task_draws_its_restitution_from_the_space():
    """``--physics-space``: ``finer`` builds PaddlesVaried (halved like the nominal task), whose reset draws the
    restitution from that space."""
    from benchmarks.design_checks.paddles_landings import finer
    from phyplan_envs import hidden_physics as hp

    base, fine = finer(2, 0, space="test"), finer(2, 1, space="test")
    assert fine.timestep == base.timestep / 2 and "Varied" in type(base).__name__
    for env in (base, fine):
        for seed in range(3):
            env.reset(seed=seed)
            e = env.hidden_physics["paddle_restitution"]
            assert hp.PADDLE_RESTITUTION.hull()[0] <= e <= hp.PADDLE_RESTITUTION.hull()[1]
            assert not hp.PADDLE_RESTITUTION.train[0] <= e <= hp.PADDLE_RESTITUTION.train[1]


def test_rebound_phase_spread_is_measured_at_the_given_timestep():
    """``rebound-phase``: PaddlesVaried's impact pair rebounds out of the board at every arrival phase, slower than
    it came in; the spread over the phases, at 0.5 ms a few percent or more, halves roughly with the timestep (a
    first-order effect of where in a step the contact starts)."""
    from benchmarks.design_checks.hidden_physics import rebound_phases

    coarse, fine = rebound_phases(0.0005, 0.15, 3.0, phases=9), rebound_phases(0.000125, 0.15, 3.0, phases=9)
    for out in (coarse, fine):
        assert len(out) == 9 and np.all(out > 0) and np.all(out < 3.0)
    assert coarse.std() / coarse.mean() > 0.02
    assert fine.std() < 0.6 * coarse.std()


def test_rebound_phase_at_a_softer_stiffness_spreads_less_and_lasts_longer():
    """``--stiffness``: the pair at K = 2e4 in place of the task's 2e5 is in contact longer, and its rebound depends
    less on the arrival phase (the task's K gives the same as the default); the CLI refuses it outside rebound-phase
    and outside [1e3, 1e7]."""
    from benchmarks.design_checks import hidden_physics as hpc

    task, task_contact = hpc.rebound_phases(0.0005, 0.15, 3.0, phases=9, contact=True)
    assert np.array_equal(task, hpc.rebound_phases(0.0005, 0.15, 3.0, phases=9, stiffness=2e5))
    soft, soft_contact = hpc.rebound_phases(0.0005, 0.15, 3.0, phases=9, stiffness=2e4, contact=True)
    assert np.all(soft > 0) and soft_contact > 1.5 * task_contact
    assert soft.std() / soft.mean() < 0.6 * task.std() / task.mean()
    for bad in (["--only", "rebound-phase", "--stiffness", "100"], ["--only", "restitution", "--stiffness", "2e4"]):
        with pytest.raises(SystemExit):
            hpc.main(bad)


def test_paddles_chaos_per_context_draws_one_chain_action_on_each_context(monkeypatch):
    """``--per-context``: K contexts (seed + step * i), one chain action each, every change tried on the action's
    own context (the fake simulator lands each attempt at its context's goal x, so no move is seen)."""
    from benchmarks.design_checks import paddles_landings as paddles

    asked = []

    def fake_chain_actions(env, context, k, rng, aimed=False):
        asked.append((context["goal"][0], k))
        return [np.array([0.3, 0.6])]

    def fake_attempt(env, context, action):
        return 1.0, float(context["goal"][0]), [True, True]

    monkeypatch.setattr(paddles, "chain_actions", fake_chain_actions)
    monkeypatch.setattr(paddles, "attempt", fake_attempt)
    c = paddles.chaos(2, 3, seed=11, deltas=[1e-4], seed_step=7)
    assert c["actions"] == 3 and c["contexts"] == 3
    assert [k for _, k in asked] == [1, 1, 1] and len({g for g, _ in asked}) == 3
    assert np.all(c["moves"][1e-4] == 0) and np.all(c["halved"] == 0)


@pytest.mark.parametrize("version", [2, 0])
def test_aimed_chain_actions_meet_every_paddle_in_one_episode_per_paddle(version, monkeypatch):
    """An aimed draw runs at most one episode per placed paddle; on Paddles-v2 and -v0 at N = 3, the draws that place
    every paddle inside its bounds are chain actions (the ball meets every paddle's face; one miss is allowed, a
    touch at the face's edge); ``chain_actions(aimed=True)`` keeps only those."""
    import benchmarks.design_checks.paddles_actions as PA

    env = PA.make(3, version=version, record_trajectory=True)
    env.reset(seed=0)
    context = env.context
    runs = []
    real = PA.flight
    monkeypatch.setattr(PA, "flight", lambda *a: runs.append(1) or real(*a))
    rng = np.random.default_rng(4)
    draws, per_draw = [], []
    for _ in range(10):
        runs.clear()
        draws.append(PA.aimed_action(env, context, rng))
        per_draw.append(len(runs))
    assert all(k == 2 for k, a in zip(per_draw, draws) if a is not None) and max(per_draw) <= 2
    placed = [a for a in draws if a is not None]           # None: a paddle's place was outside its bounds
    chained = [a for a in placed if all(PA.attempt(env, context, a)[2])]
    assert len(placed) >= 5 and len(chained) >= len(placed) - 1, draws
    assert all(np.all(env.action_low <= a) and np.all(a <= env.action_high) for a in chained)
    assert len({round(float(a[2]), 6) for a in chained}) == len(chained)        # drawn, not one fixed answer
    got = PA.chain_actions(env, context, 3, np.random.default_rng(5), aimed=True)
    assert len(got) == 3 and all(all(PA.attempt(env, context, a)[2]) for a in got)


def test_checks_without_a_chain_action_say_so(monkeypatch, capsys):
    """Where no draw gives a chain action (a design whose offsets are too short for its N), ``--chaos`` and
    ``--chain`` say so instead of failing on an empty sample."""
    import benchmarks.design_checks.paddles as P
    import benchmarks.design_checks.paddles_actions as PA

    monkeypatch.setattr(PA, "chain_action", lambda env, context, rng: None)
    assert P.main(["--chaos", "2", "--chain", "2", "--depths", "2"]) == 0
    out = capsys.readouterr().out
    assert "N=2 chain: no chain action in 10 draws" in out and "N=2 chaos: no chain action in 10 draws" in out


def test_the_episode_cap_is_the_envs_and_a_study_can_lengthen_it(capsys):
    """The end rule stops at the env's ``max_sim_time``: a study with a 1 s cap ends every Paddles-3 episode with
    the ball in the air at 1 s (it needs about 2 s to land); ``--episode-end`` counts how episodes end."""
    import benchmarks.design_checks.paddles as P
    from benchmarks.design_checks.paddles_actions import Design, episode_ends

    short = episode_ends(3, 2, seed=0, design=Design(max_sim_time=1.0))
    assert short["reasons"] == {"timeout": 2} and np.allclose(short["sim_time"], 1.0)
    task = episode_ends(3, 2, seed=0, design=Design())
    assert task["reasons"] == {"landed": 2} and np.all(task["sim_time"] < 4.0)
    assert P.main(["--episode-end", "1", "--depths", "1"]) == 0
    assert "N=1 episode ends over 1 random actions: landed 1" in capsys.readouterr().out
    with pytest.raises(SystemExit):
        P.main(["--episode-end", "1", "--max-sim-time", "0.5"])


def test_the_certificate_move_can_be_set(monkeypatch):
    """``--shift S`` is the "every paddle matters" move of ``--solvable`` (refused without it or outside (0, 2] m)."""
    import benchmarks.design_checks.paddles as P
    import benchmarks.design_checks.paddles_solver as S

    seen = []
    monkeypatch.setattr(S, "solve", lambda env, context, rng, **kw: (1.0, env.action_low.copy(), 1))
    monkeypatch.setattr(S, "paddle_matters",
                        lambda env, context, a, relative, shift, alone=False: seen.append((shift, alone)) or [0.5])
    monkeypatch.setattr(S, "attempt", lambda env, context, a, board=False: (1.0, 0.0, [True, True]))
    assert P.main(["--solvable", "1", "--depths", "2", "--shift", "0.5"]) == 0
    assert seen == [(0.5, False)]
    for argv in (["--reach", "1", "--shift", "0.5"], ["--solvable", "1", "--shift", "0"]):
        with pytest.raises(SystemExit):
            P.main(argv)


def test_move_alone_is_threaded_to_the_check_and_named_in_the_output(monkeypatch, capsys):
    """``--move-alone`` reaches ``paddle_matters`` as ``alone=True``, and the line says which check ran and on how many
    contexts no move of a paddle fitted the bounds (NaN); without it the check gets ``alone=False`` and the line is
    the one it always was."""
    import re

    import benchmarks.design_checks.paddles as P
    import benchmarks.design_checks.paddles_solver as S

    seen = []
    monkeypatch.setattr(S, "solve", lambda env, context, rng, **kw: (1.0, env.action_low.copy(), 1))
    monkeypatch.setattr(S, "paddle_matters",
                        lambda env, context, a, relative, shift, alone=False: seen.append(alone) or [np.nan, 0.5])
    monkeypatch.setattr(S, "attempt", lambda env, context, a, board=False: (1.0, 0.0, [True, True, True]))
    lines = []
    for flag in ([], ["--move-alone"]):
        capsys.readouterr()
        assert P.main(["--solvable", "1", "--depths", "3"] + flag) == 0
        lines.append(re.sub(r"\(\d+ s\)$", "(T s)", capsys.readouterr().out.strip()))
    assert seen == [False, True]
    assert lines[0] == ("N=3 solvable: 1/1 contexts at reward >= 0.95 (100%); median best 1.000, min 1.000; median "
                        "attempts 1; every paddle matters (+-0.2 m < 0.9) on 0/1 solved contexts (per placed paddle "
                        "1..2: 0, 1); the solution's ball touches every paddle on 1/1, and every paddle matters on 0 "
                        "of those (T s)")
    assert lines[1] == lines[0].replace("(+-0.2 m", "(each paddle moved alone, +-0.2 m").replace(
        " (T s)", "; no alone move fitted the bounds (per placed paddle 1..2): 1, 0; the best reward after it where "
        "one fitted: none, 0.500 to 0.500 (T s)")
