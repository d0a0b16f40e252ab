"""SETUP_SIGNING as ArduPilot honours it (GCS_MAVLINK::handle_setup_signing: the key is used at
once on every link; all zeros turns signing off), and a clean exit with TCP clients connected."""
import time

from .support import command, connect_tcp, mavlink, start_stub, wait_for, wait_heartbeat

KEY = bytes(range(1, 33))
SIGNING_EPOCH_UNIX_S = 1420070400


def stamp_now() -> int:
    return int((time.time() - SIGNING_EPOCH_UNIX_S) * 100_000)


def mode_of(conn) -> int | None:
    hb = wait_heartbeat(conn, timeout_s=5.0)
    return None if hb is None else hb.custom_mode


# The stub's clock at 5x the wall's: its 1 Hz heartbeats, which every step below waits for, come
# five times as often (nothing here depends on the pace).
SPEEDUP = ("--speedup", "5")


def test_after_setup_signing_an_unsigned_client_cannot_steer(tmp_path):
    stub = start_stub(tmp_path, *SPEEDUP)
    owner, intruder = connect_tcp(stub.tcp_port), connect_tcp(stub.tcp_port)
    try:
        assert wait_heartbeat(owner) is not None and wait_heartbeat(intruder) is not None
        owner.mav.setup_signing_send(1, 1, list(KEY), stamp_now())
        owner.setup_signing(KEY, sign_outgoing=True)
        # the stub now signs: the owner's parser accepts it (and would refuse unsigned input)
        hb = wait_heartbeat(owner)
        assert hb is not None and hb.get_signed()
        # the unsigned client asks for GUIDED: refused, no ACK, the mode stays STABILIZE
        ack = command(intruder, mavlink.MAV_CMD_DO_SET_MODE,
                      mavlink.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED, 4, timeout_s=2.0)
        assert ack is None
        assert mode_of(owner) == 0
        # the owner, signing with the key, is obeyed
        ack = command(owner, mavlink.MAV_CMD_DO_SET_MODE,
                      mavlink.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED, 5)
        assert ack is not None and ack.result == mavlink.MAV_RESULT_ACCEPTED
        assert wait_for(owner, lambda m: m.get_srcComponent() == 1 and m.custom_mode == 5, 5.0,
                        "HEARTBEAT") is not None
        # an all-zero key turns signing off again: the other client is heard once more
        owner.mav.setup_signing_send(1, 1, [0] * 32, stamp_now())
        time.sleep(0.3)
        ack = command(intruder, mavlink.MAV_CMD_DO_SET_MODE,
                      mavlink.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED, 4)
        assert ack is not None and ack.result == mavlink.MAV_RESULT_ACCEPTED
    finally:
        owner.close()
        intruder.close()
        assert stub.stop() == 0
    assert "signing on by SETUP_SIGNING" in stub.stderr()
    assert "unsigned_rejected=0" not in stub.stderr()


def test_sigterm_with_tcp_clients_connected_exits_without_a_traceback(tmp_path):
    stub = start_stub(tmp_path, *SPEEDUP)
    clients = [connect_tcp(stub.tcp_port) for _ in range(2)]
    try:
        assert all(wait_heartbeat(c) is not None for c in clients)
        assert stub.stop() == 0                   # clients still connected
    finally:
        for c in clients:
            c.close()
    err = stub.stderr()
    assert "clean shutdown" in err
    assert "Traceback" not in err and "Exception in callback" not in err, err
