"""``companion view``: a live map in a browser, from a running service's feed or a replayed tlog."""
from __future__ import annotations

import argparse
import asyncio
import signal
import sys
from pathlib import Path

from companion.errors import ConfigError

DEFAULT_SOURCE = "udp:127.0.0.1:14660"
DEFAULT_PORT = 8080


def add_parser(sub) -> None:
    p = sub.add_parser(
        "view", help="serve a live map (pose, map, movers, goal, decision, estimator state) to "
                     "a browser",
        description="Serves a page showing what the companion knows, live: from the feed of "
                    "`companion run --view-feed HOST:PORT` (or `companion demo --view-feed`), "
                    "or from a tlog replayed through the same pipeline. Open the printed address "
                    "on a laptop or phone; the page needs no network beyond this server.")
    p.add_argument("--source", default=DEFAULT_SOURCE, metavar="udp:HOST:PORT | FILE.tlog",
                   help=f"where the state comes from: the UDP address to listen on for a "
                        f"service's feed (default {DEFAULT_SOURCE}; port 0: any free port), or "
                        "a tlog to replay")
    p.add_argument("--host", default="127.0.0.1",
                   help="address the page is served on (default 127.0.0.1; 0.0.0.0 for a phone "
                        "on the same network)")
    p.add_argument("--port", type=int, default=DEFAULT_PORT,
                   help=f"TCP port of the page (default {DEFAULT_PORT}; 0: any free port)")
    p.add_argument("--truth", metavar="PATH",
                   help="a simulated flight's truth log to draw the true path and obstacles "
                        "from (`sitl-stub --truth-log`; `companion demo --keep DIR` writes "
                        "DIR/truth.jsonl)")
    p.add_argument("--config", help="with a tlog source: companion settings (default as "
                                     "`companion replay`)")
    p.add_argument("--pace", type=float, default=1.0,
                   help="with a tlog source: times the log's own speed (default 1)")
    p.set_defaults(handler=run)


def run(args: argparse.Namespace) -> int:
    from companion.view.feed import parse_address
    if not 0 <= args.port <= 65535:
        raise ConfigError(f"--port: expected 0 to 65535, got {args.port}")
    if args.pace <= 0:
        raise ConfigError(f"--pace: expected a positive number, got {args.pace}")
    replay = None
    if args.source.startswith("udp:"):
        address = parse_address(args.source, "--source")
    else:
        tlog = Path(args.source)
        if not tlog.is_file():
            raise ConfigError(f"--source: expected udp:HOST:PORT or a tlog file, got "
                              f"{args.source!r} (no such file)")
        from companion.cli.replay import choose_config
        config, _ = choose_config(argparse.Namespace(config=args.config, tlog=str(tlog),
                                                     goal=None, sysid=None))
        replay, address = (tlog, config), None
    asyncio.run(serve(args, address, replay))
    return 0


async def serve(args: argparse.Namespace, address, replay) -> None:
    from companion.view.model import ViewModel
    from companion.view.server import start_server
    from companion.view.sources import ReplayFeed, follow_truth, listen_feed
    loop = asyncio.get_running_loop()
    stop = asyncio.Event()
    for sig in (signal.SIGINT, signal.SIGTERM):
        loop.add_signal_handler(sig, stop.set)
    model = ViewModel(args.source)
    transport = None
    runner, http_port = await start_server(model, args.host, args.port)
    try:
        if address is not None:
            transport, feed_port = await listen_feed(model, *address)
            source = f"udp:{address[0]}:{feed_port}"
        else:
            source = str(replay[0])
        model.source = source
        shown_host = "127.0.0.1" if args.host in ("0.0.0.0", "") else args.host
        # One line a script can wait for (as sitl-stub's READY), then the address for people.
        print(f"COMPANION_VIEW READY http=http://{shown_host}:{http_port}/ source={source}",
              flush=True)
        feeder = ReplayFeed(model, replay[0], replay[1], args.pace) if replay else None
        async with asyncio.TaskGroup() as tg:
            tasks = []
            if args.truth:
                tasks.append(tg.create_task(follow_truth(model, Path(args.truth)), name="truth"))
            if feeder is not None:
                tasks.append(tg.create_task(feeder.run(), name="replay"))
            await stop.wait()
            if feeder is not None:
                feeder.stop()              # the replay thread ends at its next message
            for task in tasks:
                task.cancel()
    finally:
        for sig in (signal.SIGINT, signal.SIGTERM):
            loop.remove_signal_handler(sig)
        if transport is not None:
            transport.close()
        await runner.cleanup()
    print("companion view: stopped", file=sys.stderr)
