"""Time conventions shared by the engine, the tools, the planner and the generator.

One owner for: the frame of a time, and the contact-episode gap (CLEVRER's
collision definition: a pair collides anew only after this long without contact).
"""

from __future__ import annotations

import math

CONTACT_EPISODE_GAP_SECONDS = 0.2  # s: touches of one pair closer than this are one collision


def frame_of(time: float, fps: float) -> int:
    """Frame index of a time (s) at ``fps`` frames/s: round half up of ``time * fps``."""
    return int(math.floor(time * fps + 0.5))


def frames_in(seconds: float, fps: float) -> int:
    """Whole frames spanned by a duration (s), same rounding as :func:`frame_of`."""
    return frame_of(seconds, fps)
