"""The service's ``param-list`` task: a ground station's PARAM_REQUEST_LIST answered at its pace.

Wiring only: the pipeline's pacer (companion/onboard/param_pacing.py) says which values are due
and when the next is; this task sleeps until then and sends them. It waits on ``queued`` (set by
the service when a request starts a list) while nothing is being sent.
"""
from __future__ import annotations

import asyncio
from typing import Awaitable, Callable

from companion.onboard.pipeline import Pipeline


async def send_param_list(pipeline: Pipeline, queued: asyncio.Event, now_s: Callable[[], float],
                          dispatch: Callable[[object], Awaitable[None]]) -> None:
    """Runs until cancelled. ``now_s``: the clock the requests were stamped with (the link's, or
    the vehicle's in lock-step)."""
    pacer = pipeline.param_requests.pacer
    while True:
        if not pacer.sending:
            queued.clear()
            await queued.wait()
        for output in pipeline.param_tick(now_s()):
            await dispatch(output)
        due_s = pacer.next_due_s
        if due_s is not None:
            await asyncio.sleep(max(due_s - now_s(), 0.0))
