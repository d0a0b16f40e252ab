"""Link security over real loopback sockets (issue 14): who takes the udpin reply path, and
MAVLink 2 signing that survives peer changes, refuses replays and cannot be locked out by one
forged timestamp."""
import asyncio
import socket

import pytest

from companion.mavlink import codec
from companion.mavlink.dialect import mavlink
from companion.mavlink.link import open_link

KEY = bytes(range(32))
RECV_WAIT_S = 2.0            # bound on every wait for a datagram that should arrive
SILENCE_S = 0.3              # how long a datagram that must not arrive is waited for


def attitude(ms=1000):
    return mavlink.MAVLink_attitude_message(ms, 0.0, 0.0, 0.5, 0.0, 0.0, 0.0)


def udp_socket() -> socket.socket:
    sock = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    sock.bind(("127.0.0.1", 0))
    sock.setblocking(False)
    return sock


async def received(sock: socket.socket, wait_s: float) -> bytes | None:
    loop = asyncio.get_running_loop()
    try:
        async with asyncio.timeout(wait_s):
            return await loop.sock_recv(sock, 4096)
    except TimeoutError:
        return None


async def inbox_types(link, wait_s: float) -> list[str]:
    """Message types that reached the inbox within wait_s (after the last one)."""
    out = []
    try:
        async with asyncio.timeout(wait_s):
            while True:
                out.append((await link.inbox.get()).msg.get_type())
    except TimeoutError:
        return out


def forged_2_47(genuine: bytes) -> bytes:
    """The genuine packet's header and payload, stamped 2^47, with a signature we cannot make."""
    data = bytearray(genuine)
    data[-12:-6] = (2 ** 47).to_bytes(6, "little")
    data[-6:] = bytes(6)
    return bytes(data)


def run(coro):
    asyncio.run(asyncio.wait_for(coro, 30.0))


def test_junk_from_a_new_address_does_not_take_the_udpin_reply_path():
    async def scenario():
        async with open_link("udpin:127.0.0.1:0", codec.Encoder(1, 191)) as link:
            target = ("127.0.0.1", link.local_address[1])
            vehicle, intruder = udp_socket(), udp_socket()
            vehicle.sendto(codec.Encoder(1, 1).encode(codec.heartbeat()), target)
            assert await inbox_types(link, SILENCE_S) == ["HEARTBEAT"]
            intruder.sendto(b"\xfd\x09garbage that is not mavlink", target)
            intruder.sendto(b"\x00" * 40, target)
            await asyncio.sleep(SILENCE_S)
            link.send(codec.heartbeat())
            assert await received(vehicle, RECV_WAIT_S) is not None
            assert await received(intruder, SILENCE_S) is None
            assert link.statistics().unparsed_datagrams == 2
            vehicle.close(), intruder.close()
    run(scenario())


def test_a_new_udpin_peer_whose_packet_parses_takes_the_reply_path():
    async def scenario():
        async with open_link("udpin:127.0.0.1:0", codec.Encoder(1, 191)) as link:
            target = ("127.0.0.1", link.local_address[1])
            old, new = udp_socket(), udp_socket()
            old.sendto(codec.Encoder(1, 1).encode(codec.heartbeat()), target)
            await inbox_types(link, SILENCE_S)
            new.sendto(codec.Encoder(1, 1).encode(codec.heartbeat()), target)
            await inbox_types(link, SILENCE_S)
            link.send(codec.heartbeat())
            assert await received(new, RECV_WAIT_S) is not None
            assert await received(old, SILENCE_S) is None
            old.close(), new.close()
    run(scenario())


def test_signing_state_survives_a_udpin_peer_change_a_replay_from_elsewhere_is_refused():
    async def scenario():
        async with open_link("udpin:127.0.0.1:0", codec.Encoder(1, 191, KEY), signing_key=KEY) \
                as link:
            target = ("127.0.0.1", link.local_address[1])
            vehicle, intruder = udp_socket(), udp_socket()
            recorded = codec.Encoder(1, 1, KEY).encode(attitude())
            vehicle.sendto(recorded, target)
            assert await inbox_types(link, SILENCE_S) == ["ATTITUDE"]
            intruder.sendto(recorded, target)             # the same signed bytes, replayed
            assert await inbox_types(link, SILENCE_S) == []
            assert link.statistics().signature_rejected == 1
            link.send(codec.heartbeat())                  # the reply path did not move
            assert await received(vehicle, RECV_WAIT_S) is not None
            assert await received(intruder, SILENCE_S) is None
            vehicle.close(), intruder.close()
    run(scenario())


@pytest.mark.parametrize("forger_is_a_new_address", [False, True])
def test_one_forged_packet_stamped_2_47_does_not_lock_out_genuine_packets(forger_is_a_new_address):
    async def scenario():
        async with open_link("udpin:127.0.0.1:0", codec.Encoder(1, 191, KEY), signing_key=KEY) \
                as link:
            target = ("127.0.0.1", link.local_address[1])
            vehicle = udp_socket()
            forger = udp_socket() if forger_is_a_new_address else vehicle
            genuine = codec.Encoder(1, 1, KEY)
            vehicle.sendto(genuine.encode(attitude(1000)), target)
            assert await inbox_types(link, SILENCE_S) == ["ATTITUDE"]
            forger.sendto(forged_2_47(genuine.encode(attitude(1100))), target)
            for ms in (1200, 1300, 1400):
                vehicle.sendto(genuine.encode(attitude(ms)), target)
            assert await inbox_types(link, SILENCE_S) == ["ATTITUDE"] * 3
            assert link.statistics().signature_rejected == 1
            vehicle.close(), forger.close()
    run(scenario())


def test_a_forged_2_47_packet_opening_a_stream_does_not_lock_that_stream_out():
    parser = codec.Parser(KEY)
    genuine = codec.Encoder(1, 1, KEY)
    assert parser.feed(forged_2_47(genuine.encode(attitude(1000)))) == []
    assert [m.get_type() for m in parser.feed(genuine.encode(attitude(1100)))] == ["ATTITUDE"]


def test_replayed_signed_packets_are_refused_across_a_tcp_reconnect():
    async def scenario():
        async with open_link("tcpin:127.0.0.1:0", codec.Encoder(1, 191, KEY), signing_key=KEY) \
                as link:
            port = link.local_address[1]
            recorded = codec.Encoder(1, 1, KEY).encode(attitude())
            for _ in range(2):                            # connect, send, drop; again
                _, writer = await asyncio.open_connection("127.0.0.1", port)
                writer.write(recorded)
                await writer.drain()
                await asyncio.sleep(SILENCE_S)
                writer.close()
                await writer.wait_closed()
            stats = link.statistics()
            assert stats.connects == 2 and stats.received == 1 and stats.signature_rejected == 1
    run(scenario())


def test_a_truncated_datagram_does_not_swallow_the_next_one():
    async def scenario():
        async with open_link("udpin:127.0.0.1:0", codec.Encoder(1, 191)) as link:
            target = ("127.0.0.1", link.local_address[1])
            vehicle = udp_socket()
            enc = codec.Encoder(1, 1)
            vehicle.sendto(enc.encode(attitude(1000))[:20], target)     # cut short
            vehicle.sendto(enc.encode(attitude(1100)), target)
            assert await inbox_types(link, SILENCE_S) == ["ATTITUDE"]
            vehicle.close()
    run(scenario())


def test_udpout_hears_only_its_peer_not_whoever_sends_to_its_port():
    async def scenario():
        vehicle = udp_socket()
        async with open_link(f"udpout:127.0.0.1:{vehicle.getsockname()[1]}",
                             codec.Encoder(1, 191)) as link:
            ours = ("127.0.0.1", link.local_address[1])
            other_stub = udp_socket()            # still streaming to a port we now hold
            other_stub.sendto(codec.Encoder(1, 1).encode(attitude(5000)), ours)
            vehicle.sendto(codec.Encoder(1, 1).encode(attitude(1000)), ours)
            got = []
            async with asyncio.timeout(RECV_WAIT_S):
                got.append((await link.inbox.get()).msg.time_boot_ms)
            assert await inbox_types(link, SILENCE_S) == []
            assert got == [1000]
            other_stub.close()
        vehicle.close()
    run(scenario())
