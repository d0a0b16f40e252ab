"""MAVLink routing between the stub's clients, as ArduPilot's MAVLink_routing does it (``--route``).

Sans-I/O: :meth:`Router.route` learns which client a (system, component) speaks on and says, for
one received message, whether the stub's own components handle it and which other clients get it
as it came (the raw packet, signature and all). The rules (ArduPilot's
libraries/GCS_MAVLink/MAVLink_routing.cpp, as its developer wiki's "MAVLink Routing in ArduPilot"
states them):

- handled here if the message has no target_system, or target_system 0, or ours with no (or 0)
  target_component, or ours with one of our components, or ours with a component never seen
  on any link;
- sent on to another client if the message has no target_system or target_system 0 (a
  broadcast: to every other client that has spoken), or its system was seen on that client with
  its component (any component of it for target_component 0).

So a ground station's PARAM_REQUEST_LIST for the companion (1/191) reaches the companion's link
and not the autopilot, and the companion's PARAM_VALUE and STATUSTEXT (no target) reach every
ground station. A message is never sent back to the client it came from.
"""
from __future__ import annotations

from dataclasses import dataclass


@dataclass(frozen=True)
class Route:
    local: bool                     # the stub's autopilot/camera handle it
    to: tuple[str, ...]             # client names to forward the packet to


class Router:
    def __init__(self, sysid: int, components: tuple[int, ...]) -> None:
        self.sysid = sysid
        self.components = frozenset(components)
        self._seen: dict[tuple[int, int], set[str]] = {}    # (sysid, compid) -> clients
        self._clients: set[str] = set()
        self.forwarded = 0

    def forget(self, client: str) -> None:
        """A client went away: its routes with it."""
        self._clients.discard(client)
        for names in self._seen.values():
            names.discard(client)

    def route(self, client: str, msg) -> Route:
        source = (msg.get_srcSystem(), msg.get_srcComponent())
        self._clients.add(client)
        if source[0] != self.sysid or source[1] not in self.components:   # never learn ourselves
            self._seen.setdefault(source, set()).add(client)
        target_system = getattr(msg, "target_system", 0) or 0
        target_component = getattr(msg, "target_component", 0) or 0
        any_system, any_component = target_system == 0, target_component == 0
        ours = target_system == self.sysid
        local = any_system or (ours and (any_component or target_component in self.components
                                         or (target_system, target_component) not in self._seen))
        to = {name for (sys_id, comp_id), names in self._seen.items()
              if any_system or (sys_id == target_system
                                and (any_component or comp_id == target_component))
              for name in names}
        if any_system:
            to |= self._clients
        to.discard(client)
        self.forwarded += bool(to)
        return Route(local, tuple(sorted(to)))
