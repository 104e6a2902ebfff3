"""Shared fixtures: the `multistep` command line (the reference every binding result is
checked against) and a real `multistep serve` board on 127.0.0.1."""

import os
import pathlib
import shutil
import socket
import subprocess
import threading
import time

import pytest

import multistep

REPO = pathlib.Path(__file__).resolve().parents[3]


def _cli_path():
    env = os.environ.get("MULTISTEP_BIN")
    if env:
        return env
    for profile in ("release", "debug"):
        p = REPO / "target" / profile / "multistep"
        if p.exists():
            return str(p)
    found = shutil.which("multistep")
    if found:
        return found
    raise RuntimeError(
        "no multistep binary: build it (cargo build -p multistep) or set MULTISTEP_BIN"
    )


@pytest.fixture(scope="session")
def cli():
    """Runs `multistep ARGS…`; returns the CompletedProcess (text)."""
    exe = _cli_path()

    def run(*args, check=True):
        r = subprocess.run([exe, *map(str, args)], capture_output=True, text=True, timeout=300)
        if check and r.returncode != 0:
            raise AssertionError(f"multistep {' '.join(map(str, args))}: {r.stderr}")
        return r

    run.exe = exe
    return run


class Serve:
    """One `multistep serve` process with a fresh database, stopped at the end."""

    def __init__(self, exe, data, *extra):
        self.proc = subprocess.Popen(
            [exe, "serve", "--data", str(data), "--listen", "127.0.0.1:0", *extra],
            stdout=subprocess.PIPE,
            stderr=subprocess.PIPE,
            text=True,
        )
        first = self.proc.stdout.readline().strip()
        if "listening on tcp://" not in first:
            self.proc.kill()
            raise RuntimeError(f"serve said: {first!r} {self.proc.stderr.read()}")
        self.endpoint = first.split("listening on ", 1)[1]

    def stop(self):
        self.proc.terminate()
        try:
            self.proc.wait(timeout=10)
        except subprocess.TimeoutExpired:
            self.proc.kill()
            self.proc.wait()


@pytest.fixture
def serve(cli, tmp_path):
    """A started board (time runs 20× the wall clock); `.endpoint` is tcp://127.0.0.1:PORT."""
    s = Serve(cli.exe, tmp_path / "board", "--time-scale", "20")
    yield s
    s.stop()


def interrupt(script, *args, ready, timeout=10.0):
    """Runs `python -c script args…`, waits for its first line `ready`, sends SIGINT half a
    second later; returns (stdout lines after `ready`, stderr, the time SIGINT was sent)."""
    import signal
    import sys

    child = subprocess.Popen(
        [sys.executable, "-c", script, *args],
        stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
    )
    assert child.stdout.readline().strip() == ready
    time.sleep(0.5)
    sent = time.monotonic()
    child.send_signal(signal.SIGINT)
    try:
        out, err = child.communicate(timeout=timeout)
    except subprocess.TimeoutExpired:
        child.kill()
        child.communicate()
        raise AssertionError(f"Ctrl-C did not end the child within {timeout} s")
    return out.splitlines() or [""], err, sent


class Peer:
    """A TCP server on 127.0.0.1 that accepts every connection and answers each line it
    reads with `answer` (nothing: it never answers). It closes its connections after
    `life` seconds at most, so a client without a timeout fails instead of hanging."""

    def __init__(self, answer=b"", life=15.0):
        self.answer = answer
        self.life = life
        self.sock = socket.socket()
        self.sock.bind(("127.0.0.1", 0))
        self.sock.listen(8)
        self.sock.settimeout(0.1)
        self.endpoint = "tcp://127.0.0.1:%d" % self.sock.getsockname()[1]
        self.running = True
        self.conns = []
        self.thread = threading.Thread(target=self._serve, daemon=True)
        self.thread.start()

    def _serve(self):
        end = time.monotonic() + self.life
        while self.running and time.monotonic() < end:
            try:
                c, _ = self.sock.accept()
                c.settimeout(0.05)
                self.conns.append(c)
            except socket.timeout:
                pass
            for c in list(self.conns):
                try:
                    data = c.recv(4096)
                except socket.timeout:
                    continue
                except OSError:
                    self.conns.remove(c)
                    continue
                if not data:
                    self.conns.remove(c)
                    continue
                if self.answer:
                    c.sendall(self.answer * data.count(b"\n"))
        self.close_conns()

    def close_conns(self):
        for c in self.conns:
            c.close()
        self.conns = []

    def stop(self):
        self.running = False
        self.thread.join(timeout=5)
        self.sock.close()


@pytest.fixture
def silent():
    p = Peer()
    yield p
    p.stop()


@pytest.fixture
def silent_board(silent):
    """A Board connected to a server that never answers (short timeout)."""
    try:
        b = multistep.Board(silent.endpoint, timeout=0.3)
    except TypeError:  # a Board without a timeout: connect without one
        b = multistep.Board(silent.endpoint)
    yield b
    b.close()
