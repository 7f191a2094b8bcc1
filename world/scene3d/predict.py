"""From observed 3D tracks to the contact answer: identify, carry across the curtain, continue.

The latent properties are fitted on the phases before the last one (or, with
no curtain, on the observed part of the only phase); the last phase starts
from the state observed at the prediction boundary; the world continues to
the horizon and the agent-patient contact query answers.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from world.scene3d.identify import FitReport3D, identify_properties, world_from_tracks
from world.scene3d.io import AnnotationTiming
from world.scene3d.motion import gap_between, gap_to_static
from world.scene3d.rollout import predict_contact
from world.scene3d.types import State3D, Tracks3D, World3D

DEFAULT_CONTINUATION = 4.0  # s simulated past the boundary when the data set states no horizon


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
    report = identify_properties(tracks)
    starts = tuple(first / timing.fps for first, _ in timing.phase_frames)
    phase_states = tuple(states_by_frame[first] for first, _ in timing.phase_frames)
    world = world_from_tracks(tracks, report, starts, phase_states)
    boundary_time = timing.boundary_frame / timing.fps
    horizon = (timing.horizon_frames - 1) / timing.fps if timing.horizon_frames else boundary_time + DEFAULT_CONTINUATION
    contact, time, rollout = predict_contact(world, horizon, start_time=boundary_time,
                                             states=states_by_frame[timing.boundary_frame])
    closest = None if contact else _closest_approach(world, rollout, boundary_time)
    return ContactAnswer(contact, time, closest, world, report)


def _closest_approach(world: World3D, rollout, start: float) -> float | None:
    """Smallest agent-patient gap (m) over the continuation, sampled at 200 instants."""
    agent = world.role("agent")
    times = np.linspace(start, rollout.end_time, 200)
    centres = rollout.positions(agent.id, times)
    if world.patient_zone is not None:
        zone = next(b for b in world.phases[-1].static_objects if b.id == world.patient_zone)
        return float(gap_to_static(agent, zone, centres).min())
    patient = world.role("patient")
    return float(gap_between(agent, patient, centres, rollout.positions(patient.id, times)).min())
