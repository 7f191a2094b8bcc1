"""The per-request cost budget: what one call may ask the engine to compute and return.

Cost is counted in body-frames: bodies x horizon frames x the weight of the
requested trajectory detail (``full`` returns every record, so it weighs
more). Simulation time and response size both grow with it; a request above
the server's budget answers 422 ``cost_exceeded`` naming the budget.
"""

from __future__ import annotations

from typing import Any, Mapping

from tools.errors import ToolError

DETAIL_WEIGHTS = {"summary": 1, "sampled": 1, "full": 2}
# Tools that simulate a new rollout (the others read stored ones).
SIMULATING_TOOLS = ("simulate_edit", "remove_object")


def request_cost(bodies: int, horizon_frames: int, detail: str = "summary") -> int:
    """Body-frames of a rollout of ``bodies`` over ``horizon_frames``, weighted by ``detail``."""
    return int(bodies) * int(horizon_frames) * DETAIL_WEIGHTS.get(detail, 1)


def check_cost(cost: int, budget: int, *, tool: str | None, pointer: str, what: str) -> None:
    """Raise 422 ``cost_exceeded`` when ``cost`` is above ``budget``."""
    if cost > budget:
        raise ToolError(
            code="cost_exceeded", tool=tool, pointer=pointer, status=422,
            message=f"{what} costs {cost} body-frames (bodies x horizon frames x detail weight "
                    f"{DETAIL_WEIGHTS}), above this server's budget of {budget} (PHYSMIND_MAX_COST); "
                    "ask for a shorter horizon, a lighter trajectory_detail or fewer bodies",
            expected=f"a request of at most {budget} body-frames", extra={"limit": budget},
        )


def tool_call_cost(tool: str, args: Any, bodies: int, default_horizon: int) -> int:
    """The cost of running ``tool`` with ``args`` (0 for tools that only read stored rollouts).

    Arguments of the wrong type count as their defaults: schema validation
    reports them right after.
    """
    if tool not in SIMULATING_TOOLS or not isinstance(args, Mapping):
        return 0
    horizon = args.get("horizon_frames")
    horizon = horizon if isinstance(horizon, int) and not isinstance(horizon, bool) and horizon > 0 else default_horizon
    detail = args.get("trajectory_detail")
    return request_cost(bodies, horizon, detail if isinstance(detail, str) else "sampled")
