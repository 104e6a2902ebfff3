"""Every Board call is bounded: a peer that never answers, or answers half a line, ends
the call with BoardTimeoutError after the Board's timeout, and Ctrl-C ends a long wait at
once. The peers are sockets on 127.0.0.1 in this process."""

import socket
import textwrap
import time

import pytest

import multistep
from conftest import Peer, interrupt


def test_the_default_timeout_and_its_setter(silent):
    b = multistep.Board(silent.endpoint)
    assert b.timeout == multistep.DEFAULT_TIMEOUT == 10.0
    b.timeout = 0.25
    assert b.timeout == 0.25
    assert multistep.Board(silent.endpoint, timeout=2).timeout == 2.0
    assert issubclass(multistep.BoardTimeoutError, multistep.BoardError)
    assert issubclass(multistep.BoardTimeoutError, TimeoutError)


@pytest.mark.parametrize(
    "answer",
    [b"", b'[{"axis":"X","posi', b"X pos=0 state=idle\n", b"o"],
    ids=["nothing", "half a line", "data lines without ok", "half of ok"],
)
@pytest.mark.parametrize("call", ["status", "version", "wait", "raw"])
def test_a_peer_that_does_not_answer_times_out(answer, call):
    peer = Peer(answer)
    try:
        b = multistep.Board(peer.endpoint, timeout=0.5)
        t = time.monotonic()
        with pytest.raises(multistep.BoardTimeoutError) as e:
            if call == "raw":
                b.raw("help")
            elif call == "wait":
                b.wait("X", timeout=60)
            else:
                getattr(b, call)()
        took = time.monotonic() - t
        assert isinstance(e.value, TimeoutError) and "within 0.5 s" in str(e.value)
        assert 0.45 < took < 3.0, took
        # the next call waits for the reply still owed, then for its own: one timeout
        t = time.monotonic()
        with pytest.raises(multistep.BoardTimeoutError):
            b.status()
        assert time.monotonic() - t < 3.0
        b.close()
    finally:
        peer.stop()


def test_a_late_reply_is_not_taken_for_the_next_one(serve):
    # a real board: a call cut short by its timeout leaves its reply owed; the next call
    # reads past it and gets its own
    b = multistep.Board(serve.endpoint, timeout=5)
    b.timeout = 0.001
    for _ in range(20):
        try:
            b.status("X")
        except multistep.BoardTimeoutError:
            pass
    b.timeout = 10
    assert b.version().startswith("multistep-controller")
    assert b.status("Y")[0]["axis"] == "Y"
    assert b.get("X", "profile") == "trapezoid"


CONNECT = textwrap.dedent(
    r"""
    import sys, time
    import multistep
    print("connecting", flush=True)
    try:
        multistep.Board(sys.argv[1], timeout=60)
    except KeyboardInterrupt:
        print("interrupted", time.monotonic(), flush=True)
        raise
    except multistep.BoardError as e:
        print(type(e).__name__, e, flush=True)
    """
)


def test_connecting_to_a_peer_that_never_accepts_times_out_or_is_interrupted():
    # a listening socket whose backlog is full: further connections are never accepted
    # (on Linux they hang in SYN-sent); if the kernel answers them instead, skip
    s = socket.socket()
    s.bind(("127.0.0.1", 0))
    s.listen(0)
    endpoint = "tcp://127.0.0.1:%d" % s.getsockname()[1]
    fillers = []
    try:
        for _ in range(8):
            f = socket.socket()
            f.setblocking(False)
            f.connect_ex(s.getsockname())
            fillers.append(f)
        t = time.monotonic()
        try:
            multistep.Board(endpoint, timeout=0.5)
        except multistep.BoardTimeoutError as e:
            assert time.monotonic() - t < 3.0
            assert "within 0.5 s" in str(e)
        except multistep.BoardConnectionError:
            pytest.skip("the kernel answered the connection at once")
        else:
            pytest.skip("the kernel accepted the connection")
        # Ctrl-C while connecting with a long timeout
        lines, err, sent = interrupt(CONNECT, endpoint, ready="connecting")
        assert lines[0].startswith("interrupted"), (lines, err)
        assert float(lines[0].split()[1]) - sent < 1.0
    finally:
        for f in fillers:
            f.close()
        s.close()


# a child that waits on a board and is sent SIGINT half a second after it starts waiting
WAIT = textwrap.dedent(
    r"""
    import sys, time
    import multistep
    b = multistep.Board(sys.argv[1], timeout=60)
    if sys.argv[2] == "moving":
        b.move("Y", 4_000_000, vmax=1000.0)
    print("waiting", flush=True)
    try:
        b.wait(timeout=120)
    except KeyboardInterrupt:
        print("interrupted", time.monotonic(), flush=True)
        # the session is still usable after the interrupt
        if sys.argv[2] == "moving":
            b.stop()
            print("stopped", b.status("Y")[0]["state"], flush=True)
        raise
    """
)


@pytest.mark.parametrize("peer", ["silent", "moving"])
def test_ctrl_c_ends_a_long_wait_at_once(serve, peer):
    silent = Peer() if peer == "silent" else None
    endpoint = silent.endpoint if silent else serve.endpoint
    try:
        lines, err, sent = interrupt(WAIT, endpoint, peer, ready="waiting")
        assert lines[0].startswith("interrupted"), (lines, err)
        delay = float(lines[0].split()[1]) - sent
        assert delay < 1.0, delay
        assert "KeyboardInterrupt" in err
        if peer == "moving":
            assert lines[1].startswith("stopped"), lines
        print(f"interrupt after {delay * 1000:.0f} ms")
    finally:
        if silent:
            silent.stop()


def test_threads_share_one_board(serve):
    # one thread waits on a long move while another asks for status and then stops it:
    # each call takes the line in turn, and each gets its own reply
    import threading

    b = multistep.Board(serve.endpoint, timeout=10)
    b.move("Y", 4_000_000, vmax=1000.0)
    done = []
    waiter = threading.Thread(target=lambda: done.append(b.wait("Y", timeout=120) or "idle"))
    waiter.start()
    for _ in range(20):
        assert b.status("X")[0]["axis"] == "X"
        assert b.get("X", "profile") == "trapezoid"
    assert waiter.is_alive()
    b.stop("Y")
    waiter.join(timeout=60)
    assert done == ["idle"]
    b.timeout = 5
    assert b.timeout == 5
    b.close()
