"""Event-driven continuation of a 3D world and the contact query.

Between events every body follows a constant-acceleration segment
(``world.scene3d.motion``); the next event is the earliest of: a body hitting
a static face (quadratic root), a sliding body leaving its face or stopping,
two bodies touching (gap root), and the queried agent touching its target.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from world.scene3d.motion import (
    SUPPORT_SPEED, SURFACE_TOLERANCE, ZONE_TOUCH_TOLERANCE, bounce_velocity, contact_normal, first_gap_root,
    gap_between, gap_to_static, leave_face_time, pair_impulse_velocities, plane_contact_time, position_at,
    sliding_acceleration, stop_time, velocity_at,
)
from world.scene3d.types import Body3D, Face, Phase3D, State3D, StaticBox, World3D

MAX_EVENTS = 4000  # guard against endless chatter
# Resting contact between two bodies (one lying on the other) is not modelled: impulses then repeat
# without time advancing. This many collisions of one pair within RESTING_WINDOW end the rollout.
RESTING_COLLISIONS = 3
RESTING_WINDOW = 1e-4  # s
OFF_FALL_LINE_STEP = 0.02  # s: re-evaluate friction direction this often when sliding across a slope


@dataclass(frozen=True)
class Segment:
    """Body ``body_id`` moves as p0 + v0 tau + accel tau^2 / 2 for t in [t0, t1]; mode flight|slide|rest."""

    body_id: int
    t0: float
    t1: float
    p0: tuple[float, float, float]
    v0: tuple[float, float, float]
    accel: tuple[float, float, float]
    mode: str
    surface: int | None  # static box id supporting the body


@dataclass(frozen=True)
class Event3D:
    """An event: kind "surface" (impact on static ``static_id``), "collision" (bodies), "contact" (the query), "stop"."""

    time: float
    kind: str
    body_ids: tuple[int, ...]
    static_id: int | None = None


@dataclass(frozen=True)
class Rollout3D:
    """Segments and events up to ``end_time`` (s): the horizon, the queried contact, or where the
    engine stopped (``notes`` says why, e.g. two bodies came to rest on each other)."""

    segments: tuple[Segment, ...]
    events: tuple[Event3D, ...]
    end_time: float
    notes: tuple[str, ...] = ()

    def state(self, body_id: int, time: float) -> State3D:
        """Position and velocity of a body at ``time`` (within the rollout)."""
        for seg in self.segments:
            if seg.body_id == body_id and seg.t0 <= time <= seg.t1 + 1e-12:
                tau = time - seg.t0
                p0, v0, a = (np.asarray(x) for x in (seg.p0, seg.v0, seg.accel))
                return State3D(position_at(p0, v0, a, tau), velocity_at(v0, a, tau))
        raise ValueError(f"body {body_id}: no segment covers t = {time}")

    def positions(self, body_id: int, times: np.ndarray) -> np.ndarray:
        """(K, 3) centre positions of a body at times (K,)."""
        return np.stack([self.state(body_id, float(t)).position for t in times])


@dataclass
class _Moving:
    body: Body3D
    p: np.ndarray
    v: np.ndarray
    face: Face | None  # supporting face, None in flight
    dwell_until: float | None = None  # in a finite-duration impact until this time
    dwell_face: Face | None = None
    release_velocity: np.ndarray | None = None  # velocity when the impact ends


def _physical_faces(static_objects: tuple[StaticBox, ...]) -> list[Face]:
    return [face for box in static_objects if box.role != "zone" for face in box.faces()]


def _support_face(body: Body3D, p: np.ndarray, v: np.ndarray, faces: list[Face]) -> Face | None:
    """The face a body rests or slides on: centre at contact distance, inside the face, not moving off it."""
    best = None
    for face in faces:
        normal = np.asarray(face.normal)
        if normal[2] < 0.1:
            continue  # walls and undersides do not support
        rel = p - np.asarray(face.center)
        distance = float(rel @ normal) - body.half_size
        inside = abs(rel @ np.asarray(face.axis_u)) <= face.half_u and abs(rel @ np.asarray(face.axis_v)) <= face.half_v
        if abs(distance) <= SURFACE_TOLERANCE and inside and abs(float(v @ normal)) < SUPPORT_SPEED:
            if best is None or normal[2] > best.normal[2]:
                best = face
    return best


def _resolve_starting_contacts(body: Body3D, p: np.ndarray, v: np.ndarray, faces: list[Face]) -> np.ndarray:
    """The velocity (3,) of a body that starts at contact distance of a face while moving into it.

    No root of the contact distance lies ahead then (the body would pass through the face), so the
    normal part is reflected at once, scaled by the body's restitution and without a friction
    impulse: a starting state (e.g. a tracked frame) carries contact jitter of a few tenths of a m/s
    on a sliding body, which must not brake it, while a real impact keeps its rebound.
    """
    for face in faces:
        normal = np.asarray(face.normal)
        rel = p - np.asarray(face.center)
        inside = abs(rel @ np.asarray(face.axis_u)) <= face.half_u and abs(rel @ np.asarray(face.axis_v)) <= face.half_v
        v_n = float(v @ normal)
        if inside and abs(float(rel @ normal) - body.half_size) <= SURFACE_TOLERANCE and v_n < 0:
            v = v - (1.0 + body.restitution) * v_n * normal
    return v


def _acceleration(m: _Moving, gravity: float) -> np.ndarray:
    if m.dwell_face is not None:  # held at the surface: only the in-plane part of gravity acts
        n = np.asarray(m.dwell_face.normal)
        g_vec = np.array([0.0, 0.0, -gravity])
        return g_vec - float(g_vec @ n) * n
    if m.face is None:
        return np.array([0.0, 0.0, -gravity])
    return sliding_acceleration(np.asarray(m.face.normal), m.v, m.body.friction, gravity)


def _same_plane(a: Face, b: Face) -> bool:
    return bool(np.dot(a.normal, b.normal) > 0.999 and abs(np.dot(np.subtract(b.center, a.center), a.normal)) < 1e-6)


def _pair_restitution(world: World3D, a: Body3D, b: Body3D) -> float:
    for (i, j), e in world.pair_restitution:
        if {i, j} == {a.id, b.id}:
            return e
    return math.sqrt(a.restitution * b.restitution)


def simulate3d(world: World3D, phase: Phase3D, horizon: float, *, start_time: float | None = None,
               states: dict[int, State3D] | None = None, query: tuple[int, int] | None = None,
               query_static: bool = False) -> Rollout3D:
    """Roll the bodies of ``phase`` forward to ``horizon`` (absolute time, s).

    start_time/states: where to start (default: the phase's start and initial
    states), e.g. the state fitted at the last observed frame. query: (agent id,
    target id) whose first touch ends the rollout with a "contact" event; the
    target is a static zone when ``query_static``. Contact between bodies is gap <= 0,
    with a zone gap <= ZONE_TOUCH_TOLERANCE.
    """
    t = phase.start_time if start_time is None else float(start_time)
    initial = dict(phase.states) if states is None else states
    faces = _physical_faces(phase.static_objects)
    zones = {box.id: box for box in phase.static_objects}
    moving: dict[int, _Moving] = {}
    for body_id, state in initial.items():
        body = world.body(body_id)
        p, v = np.asarray(state.position, float), np.asarray(state.velocity, float)
        v = _resolve_starting_contacts(body, p, v, faces)
        face = _support_face(body, p, v, faces)
        if face is not None:
            v = v - float(v @ np.asarray(face.normal)) * np.asarray(face.normal)
        moving[body_id] = _Moving(body, p, v, face)
    segments: list[Segment] = []
    events: list[Event3D] = []
    notes: list[str] = []
    recent_collisions: dict[tuple[int, int], list[float]] = {}
    ids = sorted(moving)
    for _ in range(MAX_EVENTS):
        if t >= horizon - 1e-12:
            break
        span = horizon - t
        accel = {i: _acceleration(moving[i], world.gravity) for i in ids}
        best: tuple[float, str, tuple] = (span, "horizon", ())
        for i in ids:
            m, a = moving[i], accel[i]
            resting = m.face is not None and np.linalg.norm(m.v) < 1e-12 and np.linalg.norm(a) < 1e-12
            if resting:
                continue
            if m.dwell_until is not None:
                if m.dwell_until - t < best[0]:
                    best = (max(m.dwell_until - t, 0.0), "release", (i,))
                continue
            if m.face is not None:
                tau = leave_face_time(m.p, m.v, a, m.face, best[0])
                if tau is not None and tau < best[0]:
                    best = (tau, "leave", (i,))
                tau = stop_time(m.v, a)
                if tau is not None and tau < best[0]:
                    best = (tau, "stop", (i,))
                if np.linalg.norm(m.v) > 1e-9 and np.linalg.norm(np.cross(m.v, a)) > 1e-6 * np.linalg.norm(m.v) * max(np.linalg.norm(a), 1e-9):
                    if OFF_FALL_LINE_STEP < best[0]:
                        best = (OFF_FALL_LINE_STEP, "redirect", (i,))
            for face in faces:
                if m.face is not None and (face is m.face or _same_plane(face, m.face)):
                    continue
                tau = plane_contact_time(m.p, m.v, a, face, m.body.half_size, best[0])
                if tau is not None and tau < best[0]:
                    best = (tau, "surface", (i, face))
        pairs = [(i, j) for n, i in enumerate(ids) for j in ids[n + 1:]]
        for i, j in pairs:
            mi, mj = moving[i], moving[j]
            ai, aj = accel[i], accel[j]
            if np.linalg.norm(mi.v) + np.linalg.norm(mj.v) + np.linalg.norm(ai) + np.linalg.norm(aj) < 1e-12:
                continue
            gap = lambda tau, mi=mi, mj=mj, ai=ai, aj=aj: gap_between(  # noqa: E731
                mi.body, mj.body, position_at(mi.p, mi.v, ai, tau), position_at(mj.p, mj.v, aj, tau))
            tau = first_gap_root(gap, best[0])
            if tau is not None and tau < best[0] and (tau > 1e-9 or _closing(mi, mj)):
                best = (tau, "collision", (i, j))
        if query is not None and query_static:
            agent = moving.get(query[0])
            if agent is not None:
                zone, a = zones[query[1]], accel[query[0]]
                tau = first_gap_root(lambda tau: gap_to_static(agent.body, zone, position_at(agent.p, agent.v, a, tau)),
                                     best[0], ZONE_TOUCH_TOLERANCE)
                if tau is not None and tau <= best[0]:
                    best = (tau, "contact", (query[0],))
        tau, kind, detail = best
        for i in ids:
            m = moving[i]
            segments.append(Segment(i, t, t + tau, tuple(m.p), tuple(m.v), tuple(accel[i]),
                                    "impact" if m.dwell_face is not None else "flight" if m.face is None else ("rest" if np.linalg.norm(m.v) + np.linalg.norm(accel[i]) < 1e-12 else "slide"),
                                    None if m.face is None else m.face.box_id))
            m.p, m.v = position_at(m.p, m.v, accel[i], tau), velocity_at(m.v, accel[i], tau)
        t += tau
        if kind == "horizon":
            break
        if kind == "contact":
            events.append(Event3D(t, "contact", (query[0], query[1]), static_id=query[1]))
            break
        if kind == "stop":
            m = moving[detail[0]]
            m.v = np.zeros(3)
            events.append(Event3D(t, "stop", (m.body.id,)))
        elif kind == "leave":
            moving[detail[0]].face = None
        elif kind == "release":
            m = moving[detail[0]]
            n = np.asarray(m.dwell_face.normal)
            # the normal part comes from the impact law, the in-plane part kept evolving during the hold
            m.v = m.v - float(m.v @ n) * n + float(m.release_velocity @ n) * n
            m.dwell_until = m.dwell_face = m.release_velocity = None
        elif kind == "surface":
            i, face = detail
            m = moving[i]
            normal = np.asarray(face.normal)
            m.v = bounce_velocity(m.v, normal, m.body.restitution, m.body.friction, m.body.shape)
            if float(m.v @ normal) < SUPPORT_SPEED and normal[2] > 0.1:
                m.v = m.v - float(m.v @ normal) * normal
                m.face = face
            else:
                if m.face is not None and float(m.v @ np.asarray(m.face.normal)) > 1e-9:
                    m.face = None  # bounced off a wall or step into the air
                if m.body.impact_duration > 0:
                    m.dwell_until, m.dwell_face, m.release_velocity = t + m.body.impact_duration, face, m.v.copy()
                    m.v = m.v - float(m.v @ normal) * normal
            events.append(Event3D(t, "surface", (i,), static_id=face.box_id))
        elif kind == "collision":
            i, j = detail
            mi, mj = moving[i], moving[j]
            normal = contact_normal(mi.body, mj.body, mi.p, mj.p)
            e = _pair_restitution(world, mi.body, mj.body)
            mi.v, mj.v = pair_impulse_velocities(mi.v, mj.v, mi.body.mass, mj.body.mass, normal, e)
            for m in (mi, mj):
                if m.face is not None:
                    n = np.asarray(m.face.normal)
                    m.v = m.v - min(float(m.v @ n), 0.0) * n
                    if float(m.v @ n) > SUPPORT_SPEED:
                        m.face = None
            events.append(Event3D(t, "collision", (i, j)))
            if query is not None and not query_static and {i, j} == set(query):
                events.append(Event3D(t, "contact", (query[0], query[1])))
                break
            recent = [c for c in recent_collisions.get((i, j), []) if t - c <= RESTING_WINDOW] + [t]
            recent_collisions[(i, j)] = recent
            if len(recent) >= RESTING_COLLISIONS:
                notes.append(f"bodies {i} and {j} come to rest on each other at t = {t:.3f} s; resting contact "
                             "between bodies is not modelled, so the continuation ends there")
                break
    else:
        notes.append(f"the event cap ({MAX_EVENTS}) was reached at t = {t:.3f} s; the continuation ends there")
    return Rollout3D(tuple(segments), tuple(events), t, tuple(notes))


def _closing(a: _Moving, b: _Moving) -> bool:
    normal = contact_normal(a.body, b.body, a.p, b.p)
    return float((a.v - b.v) @ normal) > 0


def predict_contact(world: World3D, horizon: float, *, start_time: float | None = None,
                    states: dict[int, State3D] | None = None) -> tuple[bool, float | None, Rollout3D]:
    """Will the agent touch the patient (a body, or the zone ``world.patient_zone``) before ``horizon``?

    Runs the last phase from ``start_time``/``states`` (default: its own start).
    Returns (contact, time of first contact or None, the rollout).
    """
    agent = world.role("agent")
    if agent is None:
        raise ValueError("world: no body has role 'agent'")
    if world.patient_zone is not None:
        query, static = (agent.id, world.patient_zone), True
    else:
        patient = world.role("patient")
        if patient is None:
            raise ValueError("world: no patient body and no patient_zone")
        query, static = (agent.id, patient.id), False
    rollout = simulate3d(world, world.phases[-1], horizon, start_time=start_time, states=states,
                         query=query, query_static=static)
    hits = [event.time for event in rollout.events if event.kind == "contact"]
    return bool(hits), (hits[0] if hits else None), rollout
