"""The flight's contact search (:mod:`phyplan_agents.phyplan.flight`): stopping a row's search where it surely met a
face finds the contacts of the full search, searches a wrong stop again, and evaluates fewer throw rows; and the
``ends`` of :func:`phyplan_agents.phyplan.queries.first_events`."""
from __future__ import annotations

import math

import numpy as np
import pytest
import torch

from phyplan_agents.phyplan import flight
from phyplan_agents.phyplan import queries as q
from phyplan_agents.phyplan.agent import load_default_skills
from phyplan_agents.phyplan.composer import composed
from phyplan_agents.phyplan.fastnet import fast_skills

# The stop changes which rows share a batch of the throw network. The last row of a float32 batch is computed by
# another code path (the elementwise ops' scalar tail) and differs in the last bits; through up to six paddles'
# bounces and glides that moved a landing by at most 4e-5 m over 100 batches of Paddles-1..6. 1e-4 m is that.
ROUNDING = 1e-4
# A path that meets a face within rounding of its edge can turn from a face contact to an edge one (no prediction):
# once in those 100 batches (2 of 22 rows of one batch of hidden-physics Paddles-3). At most one row per batch here.
FLIPS = 1


def _agree(full, cut) -> None:
    flipped = (full.final.isnan().any(dim=1) != cut.final.isnan().any(dim=1))
    assert int(flipped.sum()) <= FLIPS
    both = ~full.final.isnan().any(dim=1) & ~cut.final.isnan().any(dim=1)
    assert both.float().mean() > 0.5
    assert torch.allclose(full.final[both], cut.final[both], rtol=0, atol=ROUNDING)


class Counting:
    """A skill model that counts the rows it is asked for (its attributes are the model's)."""

    def __init__(self, model):
        self.model, self.rows = model, 0

    def __getattr__(self, name):
        return getattr(self.model, name)

    def predict(self, x):
        self.rows += len(x)
        return self.model.predict(x)


def _skills():
    s = fast_skills(load_default_skills())
    for name in ("throw", "throw_wide", "throw_fast"):
        setattr(s, name, Counting(getattr(s, name)))
    return s


def _throw_rows(skills):
    return sum(getattr(skills, n).rows for n in ("throw", "throw_wide", "throw_fast"))


def _trace(monkeypatch, chain, rows, skills, stop: bool):
    search = flight.Flight.search
    with monkeypatch.context() as m:
        if not stop:
            m.setattr(flight.Flight, "search", lambda self, sel, t0, t1, stop_inside: search(self, sel, t0, t1, False))
        return chain.trace(rows, skills)


def _rows(chain, n, seed):
    lo, hi = chain.env.action_low, chain.env.action_high
    return lo + (hi - lo) * np.random.default_rng(seed).random((n, len(lo)))


@pytest.mark.parametrize("paddles", [2, 5])
def test_the_stop_inside_faces_finds_the_full_searchs_landings_with_fewer_throw_rows(monkeypatch, paddles):
    chain = composed("paddles", {"paddles": paddles})
    rows = _rows(chain, 300, paddles)
    skills = _skills()
    full = _trace(monkeypatch, chain, rows, skills, stop=False)
    full_rows = _throw_rows(skills)
    skills = _skills()
    cut = _trace(monkeypatch, chain, rows, skills, stop=True)
    _agree(full, cut)
    assert _throw_rows(skills) < 0.8 * full_rows           # the flights that meet a paddle stop at it


def test_a_wrong_stop_is_searched_again(monkeypatch):
    """Taking every face's plane for a sure contact stops rows where the ball crosses a plane beside its paddle:
    those rows are searched again, and the landings stay the full search's."""
    chain = composed("paddles", {"paddles": 3})
    rows = _rows(chain, 200, 7)
    full = _trace(monkeypatch, chain, rows, _skills(), stop=False)
    again = []
    search = flight.Flight.search

    def spy(self, sel, t0, t1, stop_inside):
        if not stop_inside:
            again.append(len(sel))
        return search(self, sel, t0, t1, stop_inside)

    monkeypatch.setattr(flight.Flight, "sure", lambda self, y, t, i, col: (col >= 1) & (col <= self.n_f))
    monkeypatch.setattr(flight.Flight, "search", spy)
    cut = chain.trace(rows, _skills())
    assert sum(again) > 0
    _agree(full, cut)


def test_first_events_ends_stops_a_row_after_a_sure_crossing():
    """A plane crossed where ``ends`` holds stops the row's search: the ground beyond it is not crossed and the
    horizon is the chunk's last time; where ``ends`` never holds, the search is the one without it."""
    throw = load_default_skills().throw
    vh, vv = torch.tensor([2.0, 2.0, 0.5]), torch.tensor([0.0, 0.0, 0.0])
    wall = torch.tensor([0.3, 0.3, 5.0])                      # row 2 never reaches its wall

    def measure(y, t, idx):
        return torch.stack([y[:, 1] + 1.0, wall[idx] - y[:, 0]], dim=1)

    x = torch.stack([vh, vv], 1)
    plain = q.first_events(throw, x, measure, 0.0, 1.0, final=(0,))
    never = q.first_events(throw, x, measure, 0.0, 1.0, final=(0,), ends=lambda y, t, i, col: torch.zeros_like(i) > 0)
    assert torch.equal(plain.t, never.t) and torch.equal(plain.valid, never.valid)
    sure = q.first_events(throw, x, measure, 0.0, 1.0, final=(0,), ends=lambda y, t, i, col: i == 0)
    assert sure.valid[0, 1] and not sure.valid[0, 0]          # stopped at the wall (0.15 s), before the ground
    assert sure.horizon[0] < plain.t[0, 0] and sure.t[0, 1] <= sure.horizon[0]
    assert math.isclose(float(sure.t[0, 1]), float(plain.t[0, 1]), abs_tol=1e-6)
    assert torch.equal(sure.t[1:], plain.t[1:]) and torch.equal(sure.valid[1:], plain.valid[1:])
    assert sure.valid[2, 0] and sure.t[2, 0] <= sure.horizon[2]     # the ground, a final event, stops it
