"""Lock-step (sitl_stub/lockstep.py): the stub never runs more than one step ahead of its peer,
waits for whole odometry samples only, and free-runs after its bounded wait, then locks again."""
from __future__ import annotations

import collections
import re
import time

from pymavlink.dialects.v20 import ardupilotmega as mav

from sitl_stub.lockstep import LockstepGate, odometry_last

from .support import connect_udp, start_stub, wait_until

DT_MS = 100


def lpn(t_ms: int):
    return mav.MAVLink_local_position_ned_message(t_ms, 0, 0, 0, 0, 0, 0)


def att(t_ms: int):
    return mav.MAVLink_attitude_message(t_ms, 0, 0, 0, 0, 0, 0)


def odo(t_ms: int):
    nan = float("nan")
    return mav.MAVLink_odometry_message(t_ms * 1000, 1, 12, 0, 0, nan, [1, 0, 0, 0], nan, nan,
                                        nan, nan, nan, nan, [nan] * 21, [nan] * 21, 0, 3, 0)


def test_no_peer_is_not_caught_up_and_a_peer_must_answer_each_whole_sample():
    gate = LockstepGate()
    assert not gate.caught_up()                   # hold until a companion has spoken at all
    gate.on_delivered("c", att(0))
    gate.on_delivered("c", lpn(0))
    gate.on_odometry("c", odo(0))
    assert gate.caught_up()
    gate.on_delivered("c", att(100))
    gate.on_delivered("c", lpn(100))
    assert not gate.caught_up()
    gate.on_odometry("c", odo(100))
    assert gate.caught_up()


def test_half_a_sample_is_not_waited_for():
    gate = LockstepGate()
    gate.on_delivered("c", att(0))
    gate.on_delivered("c", lpn(0))
    gate.on_odometry("c", odo(0))
    gate.on_delivered("c", lpn(100))              # its ATTITUDE was lost: no answer comes
    assert gate.caught_up()
    gate.on_delivered("c", att(200))              # its position was lost
    assert gate.caught_up()
    gate.on_delivered("c", att(300))
    gate.on_delivered("c", lpn(300))
    assert not gate.caught_up() and "answered 0.000 s of 0.300 s" in gate.lagging()


def test_clients_that_never_answer_are_not_peers_but_every_peer_is_waited_for():
    gate = LockstepGate()
    for client in ("gcs", "a", "b"):
        gate.on_delivered(client, att(0))
        gate.on_delivered(client, lpn(0))
    gate.on_odometry("a", odo(0))
    assert gate.caught_up()                       # the ground station never answers
    gate.on_odometry("b", odo(0))
    for client in ("gcs", "a", "b"):
        gate.on_delivered(client, att(100))
        gate.on_delivered(client, lpn(100))
    gate.on_odometry("a", odo(100))
    assert not gate.caught_up()
    gate.on_odometry("b", odo(100))
    assert gate.caught_up()


def test_the_position_goes_last_and_the_rest_keeps_its_order():
    items = [(1, att(5)), (1, lpn(5)), (100, mav.MAVLink_heartbeat_message(30, 8, 0, 0, 0, 3)),
             (1, mav.MAVLink_sys_status_message(*[0] * 13))]
    ordered = odometry_last(items)
    assert [m.get_type() for _, m in ordered] == ["ATTITUDE", "HEARTBEAT", "SYS_STATUS",
                                                  "LOCAL_POSITION_NED"]


def positions_until(conn, deadline_s: float, answer_up_to_ms: int | None) -> list[int]:
    """time_boot_ms of every LOCAL_POSITION_NED until the deadline, answering each with an
    ODOMETRY of its time while that time is <= answer_up_to_ms (None: always)."""
    seen = []
    while time.monotonic() < deadline_s:
        msg = conn.recv_match(type="LOCAL_POSITION_NED", blocking=True, timeout=0.05)
        if msg is None:
            continue
        seen.append(msg.time_boot_ms)
        if answer_up_to_ms is None or msg.time_boot_ms <= answer_up_to_ms:
            conn.mav.send(odo(msg.time_boot_ms))
    return seen


def test_the_stub_waits_for_its_peer_then_free_runs_then_locks_again(tmp_path):
    stub = start_stub(tmp_path, "--udp", "127.0.0.1:0", "--lockstep", "--lockstep-timeout-s", "1.5",
                      "--speedup", "20")
    conn = connect_udp(stub.udp_port)
    try:
        conn.mav.heartbeat_send(18, 8, 0, 0, 0)              # registers us: we get step 0 again
        conn.mav.command_long_send(1, 1, mav.MAV_CMD_SET_MESSAGE_INTERVAL, 0, 32, 100_000,
                                   0, 0, 0, 0, 0)
        conn.mav.command_long_send(1, 1, mav.MAV_CMD_SET_MESSAGE_INTERVAL, 0, 30, 100_000,
                                   0, 0, 0, 0, 0)
        # Answer up to 2 s of vehicle time, then stay quiet for under the timeout: the stub
        # stays one step ahead of our last answer (bounded: 21 answers, 1 s of silence).
        seen = []
        deadline = time.monotonic() + 20.0
        while 2000 not in seen and time.monotonic() < deadline:
            seen += positions_until(conn, time.monotonic() + 0.1, answer_up_to_ms=2000)
        assert 2000 in seen
        seen += positions_until(conn, time.monotonic() + 1.0, answer_up_to_ms=2000)
        assert max(seen) <= 2000 + DT_MS
        # Silent past the timeout: the stub free-runs (at 20x) with a warning.
        seen = positions_until(conn, time.monotonic() + 1.5, answer_up_to_ms=0)
        assert seen and max(seen) > 2000 + 5 * DT_MS
        wait_until(lambda: "free-running" in stub.stderr(), 5.0, "the free-run warning")
        assert re.search(r"answered 2\.000 s of 2\.100 s", stub.stderr())
        # Answering again: locked again, and one step ahead of us once more.
        positions_until(conn, time.monotonic() + 0.5, answer_up_to_ms=None)
        wait_until(lambda: "caught up" in stub.stderr(), 5.0, "the stub to lock again")
    finally:
        conn.close()
        assert stub.stop() == 0


def test_a_peer_answering_every_other_sample_is_waited_for_loosely_never_forever():
    gate = LockstepGate()
    for t in range(0, 1100, 100):                 # samples every 100 ms, answers every 200 ms
        gate.on_delivered("c", att(t))
        gate.on_delivered("c", lpn(t))
        if t % 200 == 0:
            gate.on_odometry("c", odo(t))
        assert gate.caught_up() or t == 100     # before the answer period is known: waits
    gate.on_delivered("c", att(1100))
    gate.on_delivered("c", lpn(1100))
    gate.on_delivered("c", att(1200))
    gate.on_delivered("c", lpn(1200))
    assert not gate.caught_up()                 # two samples behind: more than its period


def test_overlapped_the_stub_steps_on_the_answer_to_the_sample_before_the_latest():
    gate = LockstepGate(overlap=True)
    for t in (0, 100):
        gate.on_delivered("c", att(t))
        gate.on_delivered("c", lpn(t))
    assert not gate.caught_up()                   # no peer yet
    gate.on_odometry("c", odo(0))
    assert gate.caught_up()                       # sample 100 may still be being computed
    gate.on_delivered("c", att(200))
    gate.on_delivered("c", lpn(200))
    assert not gate.caught_up()                   # but not two samples
    gate.on_odometry("c", odo(100))
    assert gate.caught_up()


def test_overlapped_an_answer_takes_effect_one_step_after_its_sample_however_early_it_came():
    """What a peer sends for sample k (up to its ODOMETRY of k) is handled at step k + 1, never
    at step k even when it arrives before the stub looks: the flight does not depend on load."""
    from sitl_stub.__main__ import Lockstep
    from sitl_stub.lockstep import LockstepOptions

    class Hub:
        def broadcast(self, items, only=None):
            pass

    lockstep = Lockstep(LockstepOptions(overlap=True), Hub(), 1.0)
    gate, inbox = lockstep.gate, collections.deque()
    setpoint = mav.MAVLink_set_position_target_local_ned_message(
        0, 1, 1, 1, 0b110111000111, 0, 0, 0, 1.0, 0, 0, 0, 0, 0, 0, 0)

    def sample(t_ms):
        gate.on_delivered("c", att(t_ms))
        gate.on_delivered("c", lpn(t_ms))

    def answer(t_ms):                              # as the link delivers it: the hook, then it
        assert lockstep.holds("c", setpoint)
        gate.on_odometry("c", odo(t_ms))
        assert lockstep.holds("c", odo(t_ms))

    assert not lockstep.holds("c", setpoint)      # not a peer yet: handled at once
    sample(0)
    gate.on_odometry("c", odo(0))
    assert lockstep.holds("c", odo(0))
    lockstep.release(0.0, inbox)                   # step 0: the first answer, as without overlap
    assert [m.id for _, m in inbox] == [mav.MAVLINK_MSG_ID_ODOMETRY]
    inbox.clear()
    sample(100)
    answer(100)                                    # early: before the stub stepped from 0.1 s
    assert gate.caught_up()
    lockstep.release(0.1, inbox)
    assert not inbox                               # held for one step
    sample(200)
    lockstep.release(0.2, inbox)
    assert [m.get_type() for _, m in inbox] == ["SET_POSITION_TARGET_LOCAL_NED", "ODOMETRY"]
    gate.free_running = True                       # no lock, nothing held back
    answer(200)
    inbox.clear()
    lockstep.release(0.2, inbox)
    assert len(inbox) == 2
