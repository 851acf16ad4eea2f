"""One batch of rows through a scene description, event by event (the engine of
:mod:`phyplan_agents.phyplan.composer`, whose docstring states the events and the skills they call)."""
from __future__ import annotations

import math

import torch

from phyplan_envs import assets
from phyplan_envs.skill_scenes.hit_cond import ideal_hit_speed

from . import geometry as geo
from . import edge_contact as ec
from . import queries as q
from .face_bounce import face_bounce, grazing_low, in_ranges
from .flight import Flight
from .hand_over import free_states

STEP_DOWN = 0.01       # m: an edge hands the object over to a top at most this much lower that holds its path
ON_TOP = 0.002         # m: the object rests on a top whose height is within this of its bottom
BASE_EVENTS = 8        # support crossings and bounces per rollout, plus EVENTS_PER_FACE per face (a path with more
EVENTS_PER_FACE = 3    # has no prediction)
SETTLE = 0.1           # m/s: an arrival slower than this towards a face stays on it (below every bounce skill's
                       # domain: the general bounce scenes' MIN_NORMAL_SPEED)
EXACT_EDGE_GUARD = 0.03  # m: a touch of an exact-impact face this close to its edge is taken as its edge (no
                         # prediction) where the face's restitution is at least EXACT_EDGE_GUARD_FROM: the ball hops
                         # there, and whether it meets the face turns on the physics: a plan made at the wrong
                         # physics (the first attempt's, at the nominal) that aims there can miss by metres
                         # (docs/depth.md, *How wide*: 1 cm predicted as well at the true physics, planned worse)
EXACT_EDGE_GUARD_FROM = 0.07  # below this restitution a hop rises under 2 mm, and a touch up to the edge is
                              # predicted: the guard removed no more than 2 of 240 misses there (docs/depth.md)
SKIP_HOP = 0.001       # m: an exact-impact rebound whose hop would rise less than this (0.118 m/s off 45 degrees)
                       # glides on: along a frictionless face a flight moves as a glide does, and so low a hop is
                       # within the throw skill's error (its return to the face was lost: the ball flew through it)
GLIDE_T_MAX = 1.0      # s: the glide query's time range when the model has none
GLIDE_GRID_POINTS = 9  # a glide's distance to an edge is a parabola in t: one crossing, bracketed on a 75 ms grid
_TOL = 1e-6

SUPPORT, FLYING, DONE, GLIDING = 0, 1, 2, 3
WIDE = "_wide"         # a skill's wider-domain twin (e.g. throw_wide), used where the query leaves the skill's domain
FAST = "_fast"         # and its widest (throw_fast: balls bouncing off paddles), where the query leaves both


class Rollout:
    """One batch through the scene: per row the object's position, direction, speeds and phase."""

    def __init__(self, d, skills, physics, n: int, edge_guard_from: float = EXACT_EDGE_GUARD_FROM):
        self.d, self.skills, self.physics, self.n = d, skills, physics, n
        self.edge_guard_from = edge_guard_from
        self.obj = d.object
        self.pos = geo.rows(d.object.start, n, 3).clone()
        self.u = torch.tensor([1.0, 0.0]).repeat(n, 1)
        self.vh, self.vz = torch.zeros(n), torch.zeros(n)
        self.phase = torch.full((n,), FLYING, dtype=torch.long)
        self.support = torch.full((n,), -1, dtype=torch.long)
        self.final = torch.full((n, 2), float("nan"))
        self.faces = [geo.face_arrays(f, n) for f in d.faces]
        self.blocks = geo.block_arrays(d.obstacles, n) if d.obstacles else None
        self.face = torch.full((n,), -1, dtype=torch.long)     # GLIDING: the face; FLYING: the face just left
        self.glide_v = torch.zeros(n, 2)                        # GLIDING: the velocity (down, across) on the face
        self.edges = torch.zeros(n, dtype=torch.long)          # contacts at a face's edge or corner so far

    def value(self, v) -> torch.Tensor:
        """A description value per row: a fact, or the row's value of the hidden parameter it names."""
        if isinstance(v, str):
            return self.physics[v]
        return torch.full((self.n,), float(v))

    def by_domain(self, name: str, x: torch.Tensor, idx: torch.Tensor | None = None):
        """The skill ``name``'s model and its wider twins (``name + WIDE``, then ``name + FAST``, where the skills
        have them) with the rows each serves: the first whose training ranges hold the row's leading inputs ``x``
        (R, k); a row outside all stays with the skill itself (extrapolated, as without a twin). ``idx``: the rows'
        indices (default 0..R-1)."""
        idx = torch.arange(x.shape[0]) if idx is None else idx
        model = getattr(self.skills, name)
        twins = [t for t in (getattr(self.skills, name + s, None) for s in (WIDE, FAST)) if t is not None]
        own, out = torch.ones(len(idx), dtype=torch.bool), []
        left = ~in_ranges(model, x) if twins else None
        for twin in twins:
            if not left.any():                     # every row is in the skill's own ranges or a twin's already
                break
            sel = left & in_ranges(twin, x)
            left &= ~sel
            own &= ~sel
            out.append((twin, sel))
        return [(m, idx[sel]) for m, sel in [(model, own)] + out if sel.any()]

    # --- the start --------------------------------------------------------------------------------------------------
    def start(self) -> None:
        d, n = self.d, self.n
        if d.release is not None:
            self.pos = geo.rows(d.release.pos, n, 3).clone()
            return
        s = d.striker
        plane = geo.rows(s.plane, n)
        self.u = torch.stack([torch.cos(plane), torch.sin(plane)], dim=1)
        release = geo.rows(s.release, n)
        v_bob = torch.zeros(n)
        for model, rows in self.by_domain("swing", release[:, None]):
            v_bob[rows] = q.swing_bottom_speed(model, release[rows], s.length)
        under = self.support_under(self.pos, torch.ones(n, dtype=torch.bool))
        friction = torch.zeros(n)
        for j, sup in enumerate(d.supports):       # the hit's friction: the first frictional top under the object
            if sup.friction != 0:
                friction = torch.where(geo.contains(sup, self.pos[:, :2]) & (friction == 0), self.value(sup.friction),
                                       friction)
        if s.restitution is not None:           # a contact of given restitution: the conditioned hit
            m1, e = self.value(s.bob_mass), self.value(s.restitution)
            m2 = torch.full((n,), float(self.obj.mass))
            gain = q._predict(self.skills.hit_cond, torch.stack([m1, m2, e, friction, v_bob], dim=1))[:, 0]
            self.vh = gain * ideal_hit_speed(m1, m2, e, v_bob)
            x = torch.stack([m1, e, v_bob], dim=1)
        else:
            self.vh = torch.zeros(n)
            x = torch.stack([torch.full((n,), float(s.bob_mass)), torch.full((n,), float(self.obj.mass)), v_bob], 1)
            for model, rows in self.by_domain("hit", x):
                self.vh[rows] = q.hit_speed(model, float(s.bob_mass), float(self.obj.mass), v_bob[rows])
        self.support = under
        self.phase = torch.where(under >= 0, SUPPORT, FLYING)
        if self.faces:
            self.free_from_pedestal(x, under, conditioned=s.restitution is not None)

    def free_from_pedestal(self, x: torch.Tensor, under: torch.Tensor, conditioned: bool) -> None:
        """Where a flight can meet a face, a ball hit off a frictionless top with nothing under its edge (the
        pedestal, Paddles' shelf) flies from its physical state after the hit (:mod:`.hand_over`), not from its
        resting position at the outcome-equivalent speed (exact at the landing height only). ``x``: the hand-over
        skills' inputs per row but the last (the distance to the top's edge along the swing, added here); rows
        outside every nominal hand-over skill's domain keep the outcome-equivalent speed."""
        rows = under >= 0
        edge = torch.zeros(self.n)              # the skill's last input: from the start to the top's edge
        for j, sup in enumerate(self.d.supports):
            on = (under == j).nonzero()[:, 0]
            if sup.friction != 0:
                rows &= under != j
            elif len(on):
                edge[on] = geo.exit_distance(sup, self.pos[on, :2], self.u[on], on)
        x = torch.cat([x, edge[:, None]], dim=1)
        if rows.any():
            rows &= self.support_under(self.pos, rows, below=STEP_DOWN, exclude=under) < 0
        idx = rows.nonzero()[:, 0]
        if len(idx) == 0:
            return
        st = free_states(self.skills, x[idx], conditioned, float(self.obj.mass))
        idx = idx[st.ok]
        self.pos[idx, :2] += st.reach[st.ok, None] * self.u[idx]
        self.pos[idx, 2] += st.dz[st.ok]
        self.vh[idx], self.vz[idx] = st.vh[st.ok], st.vz[st.ok]
        self.support[idx] = -1
        self.phase[idx] = FLYING

    def support_under(self, pos: torch.Tensor, rows: torch.Tensor, below: float = ON_TOP,
                      exclude: torch.Tensor | None = None) -> torch.Tensor:
        """The index of the highest top under each row's object (its bottom within ``below`` above the top, none:
        -1), among the rows ``rows``; ``exclude`` (N,) a support index per row to skip."""
        bottom = pos[:, 2] - self.obj.half_height
        best = torch.full((self.n,), -1, dtype=torch.long)
        best_top = torch.full((self.n,), -math.inf)
        for j, sup in enumerate(self.d.supports):
            ok = rows & geo.contains(sup, pos[:, :2]) & (bottom - sup.top >= -ON_TOP) & (bottom - sup.top <= below)
            if exclude is not None:
                ok &= exclude != j
            better = ok & (sup.top > best_top)
            best = torch.where(better, j, best)
            best_top = torch.where(better, torch.full_like(best_top, sup.top), best_top)
        return best

    # --- on a support -------------------------------------------------------------------------------------------
    def move_on_supports(self) -> None:
        for j, sup in enumerate(self.d.supports):
            rows = (self.phase == SUPPORT) & (self.support == j)
            if not rows.any():
                continue
            idx = rows.nonzero()[:, 0]
            edge = geo.exit_distance(sup, self.pos[idx, :2], self.u[idx], idx)
            if sup.friction == 0:
                self.cross_frictionless(j, idx, edge)
            else:
                self.slide(j, sup, idx, edge)

    def cross_frictionless(self, j: int, idx: torch.Tensor, edge: torch.Tensor) -> None:
        """A frictionless top: a pad over another top is crossed at constant speed; from any other (the pedestal)
        the object flies from where it was hit."""
        rows = torch.zeros(self.n, dtype=torch.bool)
        rows[idx] = True
        lower = self.support_under(self.pos, rows, below=STEP_DOWN, exclude=torch.full((self.n,), j))
        pad = idx[lower[idx] >= 0]
        self.pos[pad, :2] += edge[lower[idx] >= 0, None] * self.u[pad]
        self.pos[pad, 2] = torch.tensor([self.d.supports[k].top for k in lower[pad].tolist()]) + self.obj.half_height
        self.support[pad] = lower[pad]
        fly = idx[lower[idx] < 0]
        self.phase[fly] = FLYING

    def slide(self, j: int, sup, idx: torch.Tensor, edge: torch.Tensor) -> None:
        if isinstance(sup.friction, str):       # a hidden friction: the friction-conditioned slide
            mu = self.value(sup.friction)[idx]
            ev = q.slide_until(self.skills.slide_cond, self.vh[idx], edge, condition=mu[:, None])
        else:
            ev = q.slide_until(self.skills.slide, self.vh[idx], edge)
        stopped = idx[~ev.valid]
        self.final[stopped] = self.pos[stopped, :2] + ev.y[~ev.valid, 0, None] * self.u[stopped]
        self.phase[stopped] = DONE
        go = idx[ev.valid]
        self.pos[go, :2] += edge[ev.valid, None] * self.u[go]
        self.vh[go] = ev.y[ev.valid, 1].clamp(min=0.0)
        # handed over to a lower top that holds the path just past the edge, else it flies from the edge
        ahead = self.pos.clone()
        ahead[:, :2] += 1e-3 * self.u
        rows = torch.zeros(self.n, dtype=torch.bool)
        rows[go] = True
        nxt = torch.full((self.n,), -1, dtype=torch.long)
        for k, other in enumerate(self.d.supports):
            if k == j or not (sup.top - STEP_DOWN <= other.top <= sup.top + _TOL):
                continue
            nxt = torch.where(rows & (nxt < 0) & geo.contains(other, ahead[:, :2]), k, nxt)
        over = go[nxt[go] >= 0]
        self.support[over] = nxt[over]
        self.pos[over, 2] = torch.tensor([self.d.supports[k].top for k in nxt[over].tolist()]) + self.obj.half_height
        off = go[nxt[go] < 0]
        self.phase[off] = FLYING
        self.vz[off] = 0.0

    # --- in flight ------------------------------------------------------------------------------------------------
    def fly(self) -> None:
        idx = (self.phase == FLYING).nonzero()[:, 0]
        if len(idx) == 0:
            return
        for throw, rows in self.by_domain("throw", torch.stack([self.vh[idx], self.vz[idx]], dim=1), idx):
            self.fly_with(throw, rows)

    def edge_guard(self, face) -> torch.Tensor:
        """Per row, how far inside ``face``'s polygon a touch must be to have a prediction (m)."""
        if face.contact != "exact_impact":
            return torch.zeros(self.n)
        hops = self.value(face.restitution) >= self.edge_guard_from
        return torch.where(hops, torch.full((self.n,), EXACT_EDGE_GUARD), torch.zeros(self.n))

    def fly_with(self, throw, idx: torch.Tensor) -> None:
        t0, t1 = q.time_range(throw, q.THROW_T_MAX)
        pos, u, vh, vz = self.pos[idx], self.u[idx], self.vh[idx], self.vz[idx]
        if not self.faces:                      # only the ground: the one-crossing query (distinct rows once)
            ev = q.throw_landing(throw, vh, vz, pos[:, 2] - self.d.landing_height)
            land = pos[:, :2] + ev.y[:, 0, None] * u
            self.final[idx] = torch.where(ev.valid[:, None], land, torch.full_like(land, float("nan")))
            self.phase[idx] = DONE
            return
        r = self.obj.radius
        faces = [(v[idx], nrm[idx]) for v, nrm in self.faces]
        left = self.face[idx]              # the face a glide just left: not met again on this flight
        blocks = None if self.blocks is None else tuple(a[idx] for a in self.blocks[:3]) + self.blocks[3:]
        flight = Flight(throw, pos, u, vh, vz, faces, left, r, self.d.landing_height, blocks,
                        [self.edge_guard(f)[idx] for f in self.d.faces])
        n_f, u3, up, where = len(faces), flight.u3, flight.up, flight.at
        t_ev, y, ok, edge = flight.contacts(t0, t1)
        rows_i = torch.arange(len(idx))
        t_ok = torch.where(ok, t_ev, torch.full_like(t_ev, math.inf))
        first = t_ok.argmin(dim=1)
        none = ~ok.any(dim=1)
        y_first = y[rows_i, first]
        p_first = where(y_first, rows_i)
        at_edge = edge[rows_i, first] & ~none
        # a plane crossed just outside a bouncing face's polygon: search the flight again with the edges as events
        # (not an exact-impact face's, guarded by EXACT_EDGE_GUARD: a touch there has no prediction)
        by_edge = torch.zeros(len(idx), dtype=torch.bool)
        n_first = torch.zeros(len(idx), 3)
        searched = [ec.bounces(face) and face.contact != "exact_impact" for face in self.d.faces]
        retry = at_edge & torch.tensor(searched + [False] * (ok.shape[1] - 1 - n_f))[(first - 1).clamp(min=0)]
        if retry.any():
            rr = retry.nonzero()[:, 0]
            c = ec.near_edges(throw, t_ev[rr, first[rr]], vh[rr], vz[rr], t0, pos[rr], u3[rr],
                              [(v[rr], nrm[rr]) for v, nrm in faces], searched, left[rr], r,
                              self.d.landing_height)
            at_edge[rr] = False
            first[rr], y_first[rr], p_first[rr] = c.column, c.y, c.p
            by_edge[rr], n_first[rr] = c.edge, c.normal
            self.edges[idx[rr[c.edge]]] += 1
            go = c.column < 0                      # nothing met in the window: the object flies on from its end
            self.pos[idx[rr[go]]], self.vz[idx[rr[go]]] = c.p_end[go], c.vz_end[go]
        ground = (first == 0) & ~none
        self.final[idx[ground]] = p_first[ground, :2]
        # a touch of an edge or corner of a face that keeps the object, or an obstacle met: no skill knows it, so no
        # prediction (NaN)
        blocked = (first > n_f) & ~none
        self.phase[idx[ground | none | at_edge | blocked]] = DONE
        none |= at_edge | blocked
        self.face[idx] = -1
        for f in range(len(faces)):
            hit = (first == f + 1) & ~none
            if not hit.any():
                continue
            v_in = vh[hit, None] * u3[hit] + y_first[hit, 2:3] * up
            edged = by_edge[hit]                       # met at an edge: its own normal; it never stays there
            normal = torch.where(edged[:, None], n_first[hit], faces[f][1][hit])
            self.pos[idx[hit]] = p_first[hit]
            face = self.d.faces[f]
            # a face that keeps none of the normal speed (restitution 0), or an arrival too slow for any bounce:
            # the object stays on the face and glides
            e = self.value(face.restitution)[idx[hit]]
            towards = (v_in * normal).sum(dim=1).abs()
            # exact impacts (a face with a glide speed): a rebound slower than it, or whose hop would rise under
            # SKIP_HOP, ends the hops
            skip = torch.sqrt(2 * assets.GRAVITY * normal[:, 2].abs() * SKIP_HOP).clamp(min=face.glide_speed)
            stays = e * towards < skip if face.glide_speed > 0 else towards < SETTLE
            if not ec.bounces(face):
                stays[:] = True
            stays &= ~edged
            if stays.any():
                self.start_glide(idx[hit][stays], f, v_in[stays], normal[stays])
            if stays.all():
                continue
            hit[hit.clone()] = ~stays
            v_in, normal, edged, e = v_in[~stays], normal[~stays], edged[~stays], e[~stays]
            out = face_bounce(self.skills, face, v_in, normal, e)
            horiz = out[:, :2]
            speed = horiz.norm(dim=1)
            self.u[idx[hit]] = torch.where(speed[:, None] > 1e-9, horiz / speed.clamp(min=1e-9)[:, None],
                                           u[hit])
            self.vh[idx[hit]] = speed
            self.vz[idx[hit]] = out[:, 2]
            bad = ~torch.isfinite(out).all(dim=1)
            # a grazing arrival at a low-restitution face (the low bounces' domain excludes it): it stays and glides
            settle = bad & ~edged & grazing_low(self.skills, face, v_in, normal, e)
            if settle.any():
                self.start_glide(idx[hit][settle], f, v_in[settle], normal[settle])
            self.phase[idx[hit][bad & ~settle]] = DONE     # outside every bounce skill's domain: no prediction (NaN)

    # --- on a face -------------------------------------------------------------------------------------------------
    def start_glide(self, idx: torch.Tensor, f: int, v_in: torch.Tensor, normal: torch.Tensor) -> None:
        """Rows ``idx`` stay on face ``f``: they glide from where they met it with the arrival's velocity along the
        face (the normal part is what the face does not give back)."""
        from phyplan_agents.skills.bounce_general import incline_frame

        frame = incline_frame(normal.double()).float()
        self.glide_v[idx] = torch.stack([(v_in * frame[:, 0]).sum(dim=1), (v_in * frame[:, 1]).sum(dim=1)], dim=1)
        self.phase[idx] = GLIDING
        self.face[idx] = f

    def glide(self) -> None:
        """Gliding rows: the ``glide`` skill until the centre passes an edge of the face's extent along its fall
        line or its level line; then they fly from there (not meeting that face again on the flight)."""
        from phyplan_agents.skills.bounce_general import incline_frame

        model = getattr(self.skills, "glide", None)
        outputs = tuple(getattr(getattr(model, "spec", None), "outputs", ()) or ("s_down", "s_across", "v_down"))
        for f, (verts, normals) in enumerate(self.faces):
            idx = ((self.phase == GLIDING) & (self.face == f)).nonzero()[:, 0]
            if len(idx) == 0:
                continue
            if model is None:                  # no glide skill: no prediction
                self.phase[idx] = DONE
                continue
            nrm = normals[idx]
            frame = incline_frame(nrm.double()).float()
            down, across = frame[:, 0], frame[:, 1]
            rel = verts[idx] - (self.pos[idx] - self.obj.radius * nrm)[:, None, :]
            s_d, s_a = (rel * down[:, None]).sum(-1), (rel * across[:, None]).sum(-1)
            d_hi, d_lo, a_hi, a_lo = s_d.max(1).values, s_d.min(1).values, s_a.max(1).values, s_a.min(1).values
            angle = torch.arccos(nrm[:, 2].clamp(-1.0, 1.0))
            x = torch.stack([angle, self.glide_v[idx, 0], self.glide_v[idx, 1]], dim=1)
            sd, sa, vd = outputs.index("s_down"), outputs.index("s_across"), outputs.index("v_down")
            va = outputs.index("v_across") if "v_across" in outputs else None

            def measure(y, t, i):
                return torch.stack([d_hi[i] - y[:, sd], y[:, sd] - d_lo[i], a_hi[i] - y[:, sa], y[:, sa] - a_lo[i]],
                                   dim=1)

            t0, t1 = q.time_range(model, GLIDE_T_MAX)
            t_ev, crossed, _ = q.first_events(model, x, measure, t0, t1, grid_points=GLIDE_GRID_POINTS,
                                             final=(0, 1, 2, 3))
            off = crossed.any(dim=1)
            t_off = torch.where(crossed, t_ev, torch.full_like(t_ev, math.inf)).min(dim=1).values
            stuck = idx[~off]
            self.phase[stuck] = DONE                # still on the face at the end of the skill's time: no prediction
            if not off.any():
                continue
            go, rows = idx[off], off.nonzero()[:, 0]
            y = q._predict(model, torch.cat([x[rows], t_off[rows, None]], dim=1))
            v_across = y[:, va] if va is not None else x[rows, 2]
            self.pos[go] += y[:, sd:sd + 1] * down[rows] + y[:, sa:sa + 1] * across[rows]
            vel = y[:, vd:vd + 1] * down[rows] + v_across[:, None] * across[rows]
            speed = vel[:, :2].norm(dim=1)
            self.u[go] = torch.where(speed[:, None] > 1e-9, vel[:, :2] / speed.clamp(min=1e-9)[:, None], self.u[go])
            self.vh[go], self.vz[go] = speed, vel[:, 2]
            self.phase[go] = FLYING                 # self.face keeps f: the flight does not meet it again

    def run(self) -> torch.Tensor:
        self.start()
        for _ in range(BASE_EVENTS + EVENTS_PER_FACE * len(self.faces)):
            if not (self.phase != DONE).any():
                break
            self.move_on_supports()
            self.fly()
            self.glide()
        return self.final
