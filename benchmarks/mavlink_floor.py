"""A true lower bound for the lock-step loop: the cost of one step's MAVLink traffic alone.

    python -m benchmarks.mavlink_floor [--repeats 5] [--tlog PATH]

The lock-step loop (``companion demo --lockstep``) is serial: each 0.1 s control step the stub
packs and sends its telemetry, the companion parses it, answers with its setpoint and
ODOMETRY, the stub parses those. Whatever the two processes compute besides, any pymavlink
loop that exchanges the same messages pays at least, per step:

- pack: building each message object from its fields and ``pack()`` (MAVLink 2, the
  ardupilotmega dialect both sides use, one encoder per source component, as sitl_stub/links.py);
- parse: ``MAVLink.parse_buffer`` of each datagram (robust parsing, as both sides do);
- UDP: ``sendto`` of each datagram on 127.0.0.1 and its ``recv`` (one message a datagram, as
  pymavlink's UDP links send them).

The messages are a real lock-step flight's: every record of the companion's tlog of the paper
scenario (both directions: the stub's telemetry and camera, the companion's ODOMETRY,
setpoints, obstacle reports and heartbeats), replayed in order. Everything runs in this one
process with both sockets, so no process wakes up, no scheduler runs and nothing else is
computed: the figure is a floor that no pymavlink-based loop of these two processes can beat
on this machine. The bound counts neither the copies the stub also sends the demo's ground
station nor the companion's tlog writing.

Each pass over the flight is timed whole; the figures are medians of ``repeats`` passes of
each part and of the combined pass (pack, send, receive, parse, message by message, as a loop
does), interleaved. The combined pass costs more than its parts run apart (each part's code
stays hot then): ``max_real_time_factor`` = 0.1 s / the smaller of the two, so that no
pymavlink loop can do better than it.
"""
from __future__ import annotations

import argparse
import json
import socket
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np
from pymavlink.dialects.v20 import ardupilotmega as mavlink

REPO = Path(__file__).resolve().parents[1]
PAPER = REPO / "config/scenarios/paper.yaml"
STEP_S = 0.1


class _Sink:
    def write(self, data: bytes) -> None:
        pass


def read_flight(tlog: Path) -> tuple[list[tuple], int]:
    """(records, steps): each record (source system, component, message class, constructor
    arguments), and the control steps the log covers (the stub's LOCAL_POSITION_NED: one a
    step in lock-step)."""
    parser = mavlink.MAVLink(None)
    parser.robust_parsing = True
    records, steps = [], 0
    data = tlog.read_bytes()
    offset = 0
    while offset + 8 <= len(data):                 # tlog: 8-byte timestamp, then one message
        start = offset + 8
        marker = data[start:start + 1]
        if marker == b"\xfd":
            length = 12 + data[start + 1] + (13 if data[start + 2] & 1 else 0)
        elif marker == b"\xfe":
            length = 8 + data[start + 1]
        else:
            raise ValueError(f"{tlog}: not a MAVLink tlog at byte {start}")
        for msg in parser.parse_buffer(data[start:start + length]) or []:
            if msg.get_type() == "BAD_DATA":
                continue
            args = [getattr(msg, name) for name in msg.fieldnames]
            args = [a.encode("ascii") if isinstance(a, str) else a for a in args]  # char[]
            records.append((msg.get_srcSystem(), msg.get_srcComponent(), type(msg), args))
            if msg.get_type() == "LOCAL_POSITION_NED":
                steps += 1
        offset = start + length
    return records, steps


def _encoders(records) -> dict:
    return {(sysid, comp): mavlink.MAVLink(_Sink(), sysid, comp)
            for sysid, comp, _, _ in records}


def pack_all(records, encoders) -> list[bytes]:
    return [cls(*args).pack(encoders[(sysid, comp)]) for sysid, comp, cls, args in records]


def parse_all(datagrams: list[bytes], parser) -> int:
    parse = parser.parse_buffer
    return sum(len(parse(d) or ()) for d in datagrams)


def udp_all(datagrams: list[bytes], sender: socket.socket, receiver: socket.socket) -> None:
    address, send, recv = receiver.getsockname(), sender.sendto, receiver.recv
    for d in datagrams:
        send(d, address)
        recv(4096)


def combined(records, encoders, parser, sender, receiver) -> int:
    """Message by message, as the loop does: pack, send, receive, parse."""
    address, send, recv, parse = receiver.getsockname(), sender.sendto, receiver.recv, \
        parser.parse_buffer
    parsed = 0
    for sysid, comp, cls, args in records:
        send(cls(*args).pack(encoders[(sysid, comp)]), address)
        parsed += len(parse(recv(4096)) or ())
    return parsed


def measure(tlog: Path, repeats: int) -> dict:
    records, steps = read_flight(tlog)
    if not records or not steps:
        return {"error": f"no flight in {tlog}", "max_real_time_factor": None}
    parser = mavlink.MAVLink(None)
    parser.robust_parsing = True
    sender = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    receiver = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    receiver.bind(("127.0.0.1", 0))
    receiver.setsockopt(socket.SOL_SOCKET, socket.SO_RCVBUF, 1 << 20)
    clock = time.perf_counter
    times: dict[str, list[float]] = {"pack": [], "parse": [], "udp": [], "combined": []}
    try:
        encoders = _encoders(records)
        datagrams = pack_all(records, encoders)
        if parse_all(datagrams, parser) != len(records):
            return {"error": "re-packed messages did not parse back one for one",
                    "max_real_time_factor": None}
        for _ in range(repeats):
            start = clock()
            datagrams = pack_all(records, encoders)
            times["pack"].append(clock() - start)
            start = clock()
            parse_all(datagrams, parser)
            times["parse"].append(clock() - start)
            start = clock()
            udp_all(datagrams, sender, receiver)
            times["udp"].append(clock() - start)
            start = clock()
            combined(records, encoders, parser, sender, receiver)
            times["combined"].append(clock() - start)
    finally:
        sender.close()
        receiver.close()
    per_step = {k: float(np.median(v)) / steps * 1e6 for k, v in times.items()}
    by_source: dict[str, int] = {}
    for sysid, comp, cls, _ in records:
        key = f"{sysid}.{comp} {cls.msgname}" if hasattr(cls, "msgname") else f"{sysid}.{comp}"
        by_source[key] = by_source.get(key, 0) + 1
    return {"messages": len(records), "steps": steps, "repeats": repeats,
            "messages_per_step": len(records) / steps,
            "bytes_per_step": sum(map(len, datagrams)) / steps,
            "pack_us_per_step": per_step["pack"], "parse_us_per_step": per_step["parse"],
            "udp_us_per_step": per_step["udp"], "combined_us_per_step": per_step["combined"],
            "sum_of_parts_us_per_step": per_step["pack"] + per_step["parse"] + per_step["udp"],
            "max_real_time_factor": STEP_S / (min(per_step["combined"], per_step["pack"]
                                                  + per_step["parse"] + per_step["udp"]) * 1e-6),
            "messages_by_source": dict(sorted(by_source.items()))}


def fly_tlog(workdir: Path) -> Path:
    """One seeded lock-step paper demo with the companion's tlog (start-up is irrelevant
    here: only its messages are used)."""
    tlog = workdir / "paper-lockstep.tlog"
    subprocess.run([sys.executable, "-m", "companion", "demo", "--scenario", str(PAPER),
                    "--lockstep", "--tlog", str(tlog), "--json", str(workdir / "demo.json")],
                   stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, cwd=REPO, check=False,
                   timeout=300)
    return tlog


def run(quick: bool, tlog: Path | None = None) -> dict:
    repeats = 5 if quick else 9
    if tlog is not None:
        return measure(tlog, repeats)
    with tempfile.TemporaryDirectory(prefix="mavlink-floor-") as tmp:
        path = fly_tlog(Path(tmp))
        if not path.exists():
            return {"error": "the lock-step demo wrote no tlog", "max_real_time_factor": None}
        return measure(path, repeats)


def print_floor(floor: dict) -> None:
    if floor.get("max_real_time_factor") is None:
        print(f"MAVLink floor of the lock-step loop: not measured ({floor.get('error')})")
        return
    print(f"MAVLink floor of the lock-step loop (pymavlink pack + parse + loopback UDP of one "
          f"step's {floor['messages_per_step']:.1f} messages, {floor['bytes_per_step']:.0f} B, "
          f"paper flight, {floor['steps']} steps): pack {floor['pack_us_per_step']:.0f} + parse "
          f"{floor['parse_us_per_step']:.0f} + UDP {floor['udp_us_per_step']:.0f} = "
          f"{floor['sum_of_parts_us_per_step']:.0f} us, together (message by message) "
          f"{floor['combined_us_per_step']:.0f} us a step: at most "
          f"{floor['max_real_time_factor']:.0f}x real time")


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeats", type=int, default=5)
    parser.add_argument("--tlog", type=Path, help="a lock-step flight's companion tlog "
                        "(default: fly the paper scenario once)")
    parser.add_argument("--json", action="store_true", help="print the figures as JSON")
    args = parser.parse_args(argv)
    if args.tlog is not None:
        floor = measure(args.tlog, args.repeats)
    else:
        with tempfile.TemporaryDirectory(prefix="mavlink-floor-") as tmp:
            floor = measure(fly_tlog(Path(tmp)), args.repeats)
    if args.json:
        print(json.dumps(floor, indent=2, allow_nan=False))
    else:
        print_floor(floor)
    return 0 if floor.get("max_real_time_factor") is not None else 1


if __name__ == "__main__":
    sys.exit(main())
