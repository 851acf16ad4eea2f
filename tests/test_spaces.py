"""phyplan_envs.spaces: the spaces made from a task's declaration, and the input checks' errors name the argument."""
from __future__ import annotations

import numpy as np
import pytest
from gymnasium import spaces as gspaces

from phyplan_envs import spaces

DIMS = (spaces.ActionDim("angle", 0.5, 1.5, "rad", "release angle"),
        spaces.ActionDim("height", 0.1, 0.3, "m", "drop height"))
LOW = np.array([0.5, 0.1])
HIGH = np.array([1.5, 0.3])


def test_spaces_follow_the_declaration():
    box = spaces.action_space(DIMS)
    assert box.dtype == np.float32 and box.shape == (2,)
    np.testing.assert_array_equal(box.low, np.float32(LOW))
    np.testing.assert_array_equal(box.high, np.float32(HIGH))
    assert spaces.observation_space("state", 6, 32).shape == (6,)
    assert spaces.observation_space("image", 6, 32).shape == (32, 32, 3)
    both = spaces.observation_space("state_image", 6, 32)
    assert isinstance(both, gspaces.Dict) and set(both.spaces) == {"state", "image"}
    assert both["state"].high[0] == spaces.STATE_BOUND and both["image"].dtype == np.uint8


def test_check_action_accepts_shapes_and_bound_rounding():
    a, clipped = spaces.check_action([[1.0, 0.2]], DIMS, LOW, HIGH, False, "t")
    assert a.dtype == np.float64 and a.shape == (2,) and not clipped
    edge = np.float32(HIGH).astype(np.float64)                 # float32 bounds round by less than ACTION_TOL
    a, clipped = spaces.check_action(edge, DIMS, LOW, HIGH, False, "t")
    assert not clipped and np.all(a <= HIGH)
    a, clipped = spaces.check_action([2.0, 0.0], DIMS, LOW, HIGH, True, "t")
    assert clipped and a.tolist() == [1.5, 0.1]


@pytest.mark.parametrize("action, match", [
    ([1.0], "shape"), ([np.nan, 0.2], r"non-finite values in \['angle'\]"),
    ([1.0, 0.5], r"height=0.5 not in \[0.1, 0.3\] m"),
])
def test_check_action_errors_name_the_dimension(action, match):
    with pytest.raises(ValueError, match=match):
        spaces.check_action(action, DIMS, LOW, HIGH, False, "mytask")
    with pytest.raises(ValueError, match="^mytask: "):
        spaces.check_action(action, DIMS, LOW, HIGH, False, "mytask")


@pytest.mark.parametrize("action", ["x", ["1.0", "0.2"], [1 + 2j, 0.2], [True, False], [object(), 0.2], {"a": 1}])
def test_check_action_refuses_non_real_values(action):
    """Strings, complex numbers, bools and objects are a TypeError (np.asarray(..., float) would cast some)."""
    with pytest.raises(TypeError, match="^mytask: action must be numeric"):
        spaces.check_action(action, DIMS, LOW, HIGH, False, "mytask")


def test_context_checks_copy_and_name_the_argument():
    ctx = {"goal": [0.3, 0.4], "angle": np.array([1.0]), "name": "x"}
    out = spaces.check_context(ctx, ("goal", "angle", "name"), lambda name, value: value)
    assert out["goal"].dtype == np.float64 and out["name"] == "x"
    ctx["angle"][0] = 2.0
    assert out["angle"][0] == 1.0                              # no memory shared with the caller's context
    goal = np.array([0.1, 0.2])
    assert not np.shares_memory(spaces.check_goal(goal, "g"), goal)
    with pytest.raises(TypeError, match="context"):
        spaces.check_context([0.3, 0.4])
    with pytest.raises(ValueError, match=r"unknown entries \['angle', 'name'\]; a context of this task holds: goal"):
        spaces.check_context(ctx)
    with pytest.raises(ValueError, match=r"context'\]\['goal'\]"):
        spaces.check_context({"goal": [0.3, np.inf]})
    with pytest.raises(TypeError, match=r"options\['goal'\] must be two finite numbers"):
        spaces.check_goal({"x": 1}, "options['goal']")
    with pytest.raises(ValueError, match=r"options\['goal'\]"):
        spaces.check_goal([1, 2, 3], "options['goal']")
    with pytest.raises(ValueError, match=r"unknown reset options \['seed'\]; known: context, goal"):
        spaces.check_reset_options({"seed": 1}, ("context", "goal"))
    assert spaces.check_reset_options(None, ("context",)) == {}
    for bad in (5, "abc", [("goal", 1)]):
        with pytest.raises(TypeError, match="reset options must be a dict"):
            spaces.check_reset_options(bad, ("context", "goal"))


@pytest.mark.parametrize("kw, error, match", [
    ({"obs_mode": "rgb"}, ValueError, "obs_mode"), ({"render_mode": "human"}, ValueError, "render_mode"),
    ({"image_size": 8}, ValueError, "image_size"), ({"image_size": 64.0}, TypeError, "image_size"),
    ({"image_size": True}, TypeError, "image_size"), ({"obs_mode": 3}, TypeError, "obs_mode"),
    ({"render_mode": ["rgb_array"]}, TypeError, "render_mode"),
    ({"clip_actions": "no"}, TypeError, "clip_actions must be True or False, got str 'no'"),
    ({"with_panda": 1}, TypeError, "with_panda"),
])
def test_constructor_checks_name_the_argument(kw, error, match):
    args = {"obs_mode": "state", "render_mode": None, "image_size": 64, **kw}
    with pytest.raises(error, match=match):
        spaces.check_env_args(**args)
    assert spaces.check_env_args("image", "rgb_array", np.int64(64)) == 64
