"""The asyncio link over real loopback sockets and a pseudo-terminal: both directions, counters,
TCP reconnection, URL errors."""
import asyncio
import os
import time

import pytest

from companion.mavlink import codec
from companion.mavlink.link import open_link, parse_url
from companion.errors import LinkError


async def next_message(link, timeout_s=5.0):
    async with asyncio.timeout(timeout_s):
        return (await link.inbox.get()).msg


def test_urls_parse_and_mistakes_are_named():
    assert parse_url("udpin:0.0.0.0:14550").kind == "udpin"
    assert parse_url("udp:127.0.0.1:14550").kind == "udpin"
    assert parse_url("/dev/ttyACM0:115200").port == 115200
    assert parse_url("/dev/ttyUSB0,57600").host == "/dev/ttyUSB0"
    with pytest.raises(LinkError, match="unknown link type"):
        parse_url("http://x:1")
    with pytest.raises(LinkError, match="expected tcp:HOST:PORT"):
        parse_url("tcp:localhost")


def test_udpout_to_udpin_both_ways_with_timestamps_and_counters():
    async def scenario():
        async with open_link("udpin:127.0.0.1:0", codec.Encoder(1, 1)) as vehicle:
            port = vehicle.local_address[1]
            async with open_link(f"udpout:127.0.0.1:{port}", codec.Encoder(1, 191)) as us:
                sent = us.send(codec.heartbeat())
                msg = await next_message(vehicle)
                assert bytes(msg.get_msgbuf()) == sent
                vehicle.send(codec.gcs_heartbeat())             # replies to the last sender
                back = await next_message(us)
                assert back.get_srcSystem() == 1 and back.get_srcComponent() == 1
                before = us.now_us()
                assert abs(before / 1e6 - time.time()) < 1.0
                return us.statistics(), vehicle.statistics()
    ours, theirs = asyncio.run(scenario())
    assert (ours.sent, ours.received, theirs.received, theirs.sent) == (1, 1, 1, 1)
    assert ours.bad_packets == 0 and ours.dropped_inbound == 0


def test_udpin_cannot_send_before_hearing_a_peer_and_counts_it():
    async def scenario():
        async with open_link("udpin:127.0.0.1:0", codec.Encoder(1, 191)) as link:
            assert link.send(codec.heartbeat()) is None
            return link.statistics()
    assert asyncio.run(scenario()).dropped_outbound == 1


def test_full_inbox_drops_the_oldest():
    async def scenario():
        async with open_link("udpin:127.0.0.1:0", codec.Encoder(1, 1), inbox_size=10) as vehicle:
            port = vehicle.local_address[1]
            async with open_link(f"udpout:127.0.0.1:{port}", codec.Encoder(1, 191)) as us:
                for _ in range(15):
                    us.send(codec.heartbeat())
                async with asyncio.timeout(5):
                    while vehicle.statistics().received < 15:
                        await asyncio.sleep(0.01)
                first = (await vehicle.inbox.get()).msg
                return vehicle.statistics(), first.get_seq()
    stats, first_seq = asyncio.run(scenario())
    assert stats.dropped_inbound == 5 and first_seq == 5


def test_tcp_client_reconnects_when_the_server_comes_back():
    async def scenario():
        connects = []
        async with open_link("tcpin:127.0.0.1:0", codec.Encoder(1, 1)) as server:
            port = server.local_address[1]
        async with open_link(f"tcp:127.0.0.1:{port}", codec.Encoder(1, 191),
                             reconnect_interval_s=0.05) as client:
            client.on_connect = lambda: connects.append(True)
            runner = asyncio.create_task(client.run())
            try:
                await asyncio.sleep(0.2)                         # nobody listening yet
                async with open_link(f"tcpin:127.0.0.1:{port}", codec.Encoder(1, 1)) as server:
                    async with asyncio.timeout(5):
                        while not connects:
                            await asyncio.sleep(0.01)
                    client.send(codec.heartbeat())
                    assert (await next_message(server)).get_srcComponent() == 191
            finally:
                runner.cancel()
                await asyncio.gather(runner, return_exceptions=True)
        return client.statistics()
    stats = asyncio.run(scenario())
    assert stats.connects == 1 and stats.sent == 1


def test_serial_link_over_a_pseudo_terminal():
    master, slave = os.openpty()
    name = os.ttyname(slave)

    async def scenario():
        async with open_link(f"{name}:115200", codec.Encoder(1, 191)) as link:
            os.write(master, codec.Encoder(1, 1).encode(codec.gcs_heartbeat()))
            msg = await next_message(link)
            sent = link.send(codec.heartbeat())
            return msg, sent
    try:
        msg, sent = asyncio.run(scenario())
        assert msg.get_srcComponent() == 1
        assert os.read(master, 1024) == sent
    finally:
        os.close(master)
        os.close(slave)


def test_opening_a_busy_port_is_a_link_error():
    async def scenario():
        async with open_link("udpin:127.0.0.1:0", codec.Encoder(1, 1)) as first:
            port = first.local_address[1]
            async with open_link(f"udpin:127.0.0.1:{port}", codec.Encoder(1, 1)):
                pass
    with pytest.raises(LinkError, match="cannot open udpin"):
        asyncio.run(scenario())


def test_coalesced_sends_go_out_as_one_datagram_in_order_counted_and_recorded_each():
    import socket

    from pymavlink.dialects.v20 import ardupilotmega as mavlink

    async def scenario():
        peer = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
        peer.bind(("127.0.0.1", 0))
        peer.settimeout(5.0)
        recorded = []
        try:
            async with open_link(f"udpout:127.0.0.1:{peer.getsockname()[1]}",
                                 codec.Encoder(1, 191)) as us:
                us.on_sent = lambda t_us, data: recorded.append(data)
                with us.coalesced():
                    sent = [us.send(codec.heartbeat()) for _ in range(3)]
                    assert recorded == []                      # held until the block ends
                    with us.coalesced():                       # nested: still the outer block
                        sent.append(us.send(codec.gcs_heartbeat()))
                burst = await asyncio.to_thread(peer.recv, 65536)
                us.send(codec.heartbeat())                     # outside: a datagram of its own
                single = await asyncio.to_thread(peer.recv, 65536)
                return sent, burst, single, recorded, us.statistics()
        finally:
            peer.close()
    sent, burst, single, recorded, stats = asyncio.run(scenario())
    assert burst == b"".join(sent)
    parsed = mavlink.MAVLink(None).parse_buffer(burst)
    assert [m.get_seq() for m in parsed] == [0, 1, 2, 3]
    assert len(mavlink.MAVLink(None).parse_buffer(single)) == 1
    assert recorded[:4] == sent and stats.sent == 5
