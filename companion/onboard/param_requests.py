"""A ground station's PARAM_* requests in the pipeline: reads and sets answered at once, the
list paced, live sets queued.

The server (parameters.py) answers and checks; here its replies and notices go out, refusals
are counted and logged, and a live set's new config waits (``pending``) for the pipeline's next
safe point: a message boundary with no camera frame in assembly, never inside a decision. A
PARAM_REQUEST_LIST's values go out one list at a time at ``link.param_rate_hz``
(param_pacing.py), on the service's timer (``tick``).
"""
from __future__ import annotations

import logging

from companion.config.service import CompanionConfig
from companion.mavlink import codec
from companion.onboard.param_pacing import ParamListPacer
from companion.onboard.parameters import ParamRequest, ParamServer, ParamValue

log = logging.getLogger(__name__)


class ParamRequests:
    """The parameter server and the config a live set has queued.

    ``pipeline``: the pipeline this part serves (its config, vehicle and clock are read at each
    request).
    """

    def __init__(self, pipeline, config: CompanionConfig) -> None:
        self._pipeline = pipeline
        self.server = ParamServer(config, require_signed=config.link.signing_key_file is not None)
        self.pending: CompanionConfig | None = None
        self.pacer: ParamListPacer[ParamValue] = ParamListPacer(config.link.param_rate_hz)

    def tick(self, t_link_s: float) -> list[ParamValue]:
        """The list's values due at ``t_link_s`` (the same clock as the requests')."""
        return self.pacer.due(t_link_s)

    def on_request(self, t_link_s: float, request: ParamRequest, out: list) -> None:
        """A ground station's PARAM_* (companion/onboard/parameters.py); a live set is queued for the
        next safe point (Pipeline.handle(): between messages, no camera frame in assembly)."""
        p = self._pipeline
        vehicle = p.vehicle
        our_system = p.config.link.system_id or (vehicle[0] if vehicle else 1)
        outcome = self.server.handle(request, our_system, p.config.link.component_id,
                                     p.clock.latest_t_s if p.clock.latest_t_s is not None
                                     else t_link_s)
        if request.kind == "list":
            if outcome.replies and not self.pacer.request(t_link_s, outcome.replies):
                p.count("param_list_folded")      # one is being sent: it serves this one too
            out.extend(self.pacer.due(t_link_s))
        else:
            out.extend(outcome.replies)
        for notice in outcome.notices:
            warn = notice.severity == "warning"
            if warn:
                p.count("param_refused")
                log.warning("PARAM_%s from %d/%d: %s", request.kind.upper(), request.system_id,
                            request.component_id, self.server.last_refusal)
            out.append(codec.Notice(codec.SEVERITY_WARNING if warn else codec.SEVERITY_INFO,
                                    notice.text))
        change = outcome.change
        if change is not None:
            log.info("parameter %s (%s) %r -> %r from %d/%d: %s", change.name, change.key,
                     change.old, change.new, *change.source,
                     "live at the next safe point" if change.live else "at the next start")
            if change.config is not None:
                self.pending = change.config
            out.append(change)
