"""From observed 3D tracks to the contact answer: identify, carry across the curtain, continue.

The latent properties are fitted on the phases before the last one (or, with
no curtain, on the observed part of the only phase); the world is anchored at
the state observed at the prediction boundary (the last observed frame); its
factual continuation runs to the horizon and the contact query answers.
``contact_query`` is the one place a contact question about a 3D world is
answered: the eval and the tools (check_contact) both call it.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from world.scene3d.identify import FitReport3D, identify_properties, world_from_tracks
from world.scene3d.io import AnnotationTiming
from world.scene3d.motion import gap_between, gap_to_static
from world.scene3d.rollout import Rollout3D, simulate3d
from world.scene3d.types import Anchor3D, State3D, Tracks3D, World3D

DEFAULT_CONTINUATION = 4.0  # s simulated past the boundary when the data set states no horizon


def default_horizon_frames(world: World3D) -> int:
    """Frames (from frame 0) of the factual continuation: the world's stated horizon, else
    DEFAULT_CONTINUATION seconds past the last observed frame."""
    if world.horizon_frames is not None:
        return world.horizon_frames
    return world.observed_frames + int(round(DEFAULT_CONTINUATION * world.fps))


def frame_time(world: World3D, frame: int) -> float:
    """Time (s) of a frame of the world's video."""
    return frame / world.fps


def factual_rollout(world: World3D, horizon_frames: int, query: tuple[int, int] | None = None,
                    query_static: bool = False) -> Rollout3D:
    """The unedited continuation from the anchor to frame ``horizon_frames - 1`` (see simulate3d for ``query``)."""
    end = max(frame_time(world, horizon_frames - 1), world.start_time)
    return simulate3d(world, world.phases[-1], end, start_time=world.start_time, states=world.start_states,
                      query=query, query_static=query_static)


@dataclass(frozen=True)
class ContactOutcome:
    """contact: does ``body_id`` touch ``target_id`` (a body, or a static zone when ``target_is_zone``)
    before the horizon; time: first contact (s) or None; closest, closest_time: the smallest gap (m)
    over the continuation and when (s), sampled at every frame; rollout: the continuation searched."""

    body_id: int
    target_id: int
    target_is_zone: bool
    contact: bool
    time: float | None
    closest: float
    closest_time: float
    rollout: Rollout3D


def contact_query(world: World3D, body_id: int, target_id: int, horizon_frames: int) -> ContactOutcome:
    """Will body ``body_id`` touch ``target_id`` in the factual continuation?

    ``target_id`` names a body of the world, else a zone of the last phase (a body id wins).
    ValueError names the id when it is neither.
    """
    world.body(body_id)
    body_ids = {body.id for body in world.bodies}
    zone = None if target_id in body_ids else world.static_object(target_id)
    if target_id not in body_ids and (zone is None or zone.role != "zone"):
        raise ValueError(f"object {target_id}: neither a body nor a zone of the last phase")
    if body_id not in world.start_states:
        raise ValueError(f"object {body_id}: not present when the continuation starts")
    rollout = factual_rollout(world, horizon_frames, query=(body_id, target_id), query_static=zone is not None)
    hits = [event.time for event in rollout.events if event.kind == "contact"]
    closest, closest_time = closest_approach(world, rollout, body_id, target_id, zone is not None)
    return ContactOutcome(body_id, target_id, zone is not None, bool(hits), hits[0] if hits else None,
                          closest, closest_time, rollout)


def closest_approach(world: World3D, rollout: Rollout3D, body_id: int, target_id: int, target_is_zone: bool,
                     window: tuple[float, float] | None = None) -> tuple[float, float]:
    """Smallest gap (m) between a body and a body or zone over a rollout, and its time (s); sampled at every
    frame of the world's video within ``window`` (s, default the whole rollout), both ends included."""
    start, end = window if window is not None else (world.start_time, rollout.end_time)
    start, end = max(start, world.start_time), min(end, rollout.end_time)
    first, last = int(np.ceil(start * world.fps - 1e-9)), int(np.floor(end * world.fps + 1e-9))
    times = np.unique(np.clip(np.concatenate([[start], np.arange(first, last + 1) / world.fps, [end]]), start, end))
    centres = rollout.positions(body_id, times)
    body = world.body(body_id)
    if target_is_zone:
        gaps = gap_to_static(body, world.static_object(target_id), centres)
    else:
        if target_id not in world.start_states:
            return float("inf"), start
        gaps = gap_between(body, world.body(target_id), centres, rollout.positions(target_id, times))
    k = int(np.argmin(gaps))
    return float(max(gaps[k], 0.0)), float(times[k])


def contact_target(world: World3D) -> int:
    """The agent's target: the patient zone, else the patient body. ValueError if the world has neither."""
    if world.patient_zone is not None:
        return world.patient_zone
    patient = world.role("patient")
    if patient is None:
        raise ValueError("world: no patient body and no patient_zone")
    return patient.id


@dataclass(frozen=True)
class FittedWorld:
    """The identified world (anchored at the prediction boundary) and the fit report it rests on."""

    world: World3D
    report: FitReport3D


def fit_world(tracks: Tracks3D, timing: AnnotationTiming, states_by_frame: dict[int, dict[int, State3D]]) -> FittedWorld:
    """Identify the latent properties, carry them across the curtains, anchor at the boundary frame."""
    report = identify_properties(tracks)
    starts = tuple(first / timing.fps for first, _ in timing.phase_frames)
    phase_states = tuple(states_by_frame[first] for first, _ in timing.phase_frames)
    anchor = Anchor3D(timing.boundary_frame / timing.fps, tuple(sorted(states_by_frame[timing.boundary_frame].items())))
    world = world_from_tracks(tracks, report, starts, phase_states, fps=timing.fps, anchor=anchor,
                              horizon_frames=timing.horizon_frames)
    return FittedWorld(world, report)


@dataclass(frozen=True)
class ContactAnswer:
    """contact: the answer; time: first contact (s) or None; closest: closest approach (m) over the
    continuation when there is no contact; world and report: what the answer rests on."""

    contact: bool
    time: float | None
    closest: float | None
    world: World3D
    report: FitReport3D


def answer_contact(tracks: Tracks3D, timing: AnnotationTiming, states_by_frame: dict[int, dict[int, State3D]]) -> ContactAnswer:
    """Fit the world and ask whether the agent touches the patient (body or zone) before the horizon."""
    fitted = fit_world(tracks, timing, states_by_frame)
    world = fitted.world
    agent = world.role("agent")
    if agent is None:
        raise ValueError("world: no body has role 'agent'")
    outcome = contact_query(world, agent.id, contact_target(world), default_horizon_frames(world))
    return ContactAnswer(outcome.contact, outcome.time, None if outcome.contact else outcome.closest, world, fitted.report)
