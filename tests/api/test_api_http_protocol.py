"""app.http_protocol: each response's head and body leave in one write, nothing is lost or
delayed past the loop's turn, and the service behaves the same over it (real uvicorn)."""
from __future__ import annotations

import asyncio
import contextlib
import json
import socket
import threading
import time

import pytest

from api_conftest import db_path, make_settings, sim_body  # noqa: F401 (fixture)

from app.http_protocol import PROTOCOL, CombinedWrites


class FakeTransport:
    """Records what reaches the socket, one entry per system call."""

    def __init__(self):
        self.calls, self.closed, self.aborted = [], False, False

    def write(self, data):
        self.calls.append([bytes(data)])

    def writelines(self, chunks):
        self.calls.append([bytes(c) for c in chunks])

    def is_closing(self):
        return self.closed or self.aborted

    def close(self):
        self.closed = True

    def abort(self):
        self.aborted = True

    def get_write_buffer_size(self):
        return 0

    def get_extra_info(self, name, default=None):
        return {"peername": ("127.0.0.1", 1)}.get(name, default)


def test_a_write_leaves_with_the_next_one():
    async def main():
        t = FakeTransport()
        w = CombinedWrites(t, asyncio.get_running_loop())
        w.write(b"HTTP/1.1 200 OK\r\n\r\n")
        w.write(b"")                      # nothing to send: no call
        assert t.calls == []              # the head is held...
        assert w.get_write_buffer_size() == 19
        w.write(b"body")                  # ...and leaves with the body, at once
        assert t.calls == [[b"HTTP/1.1 200 OK\r\n\r\nbody"]]
        w.write(bytearray(b"next"))       # held alone: it leaves at flush (response complete)
        w.flush()
        assert t.calls[1:] == [[b"next"]]
        w.write(b"slow head")             # or at the end of the loop's turn
        await asyncio.sleep(0)
        await asyncio.sleep(0)
        assert t.calls[2:] == [[b"slow head"]]
        assert w.get_extra_info("peername") == ("127.0.0.1", 1)   # the rest is the transport's
    asyncio.run(main())


def test_close_sends_what_is_held_first_and_abort_drops_it():
    async def main():
        t = FakeTransport()
        w = CombinedWrites(t, asyncio.get_running_loop())
        w.write(b"head")
        w.close()
        assert t.calls == [[b"head"]] and t.closed
        await asyncio.sleep(0)            # the end of the turn finds nothing left
        assert len(t.calls) == 1
        t2 = FakeTransport()
        w2 = CombinedWrites(t2, asyncio.get_running_loop())
        w2.write(b"lost")
        w2.abort()
        await asyncio.sleep(0)
        assert t2.calls == [] and t2.aborted
    asyncio.run(main())


# ----------------------------------------------------------------------------- a real server
@contextlib.contextmanager
def server(db_path, **limits):
    """uvicorn with the app's protocol (as ``python -m app`` runs it) in a thread."""
    import uvicorn

    from app.main import create_app
    app = create_app(make_settings(db_path, **limits))
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        port = s.getsockname()[1]
    srv = uvicorn.Server(uvicorn.Config(app, host="127.0.0.1", port=port, log_level="warning",
                                        lifespan="on", http=PROTOCOL))
    th = threading.Thread(target=srv.run, daemon=True)
    th.start()
    t0 = time.monotonic()
    while not srv.started:
        # start-up budget: a bound on a hang, not a speed claim
        assert time.monotonic() - t0 < 30.0 and th.is_alive(), "uvicorn did not start"
        time.sleep(0.01)
    try:
        yield port
    finally:
        srv.should_exit = True
        th.join(timeout=30)


def read_response(sock, head_only=False):
    """(status, headers, body) of one HTTP/1.1 response with a Content-Length (``head_only``:
    the answer to a HEAD request, whose Content-Length announces no body)."""
    buf = b""
    while b"\r\n\r\n" not in buf:
        chunk = sock.recv(65536)
        assert chunk, "connection closed before the headers"
        buf += chunk
    head, _, body = buf.partition(b"\r\n\r\n")
    lines = head.decode("latin-1").split("\r\n")
    headers = {k.strip().lower(): v.strip() for k, _, v in (ln.partition(":") for ln in lines[1:])}
    n = 0 if head_only else int(headers.get("content-length", "0"))
    while len(body) < n:
        chunk = sock.recv(65536)
        assert chunk, "connection closed before the body"
        body += chunk
    return int(lines[0].split()[1]), headers, body


def request(method, path, body=b"", extra=b""):
    return (f"{method} {path} HTTP/1.1\r\nhost: 127.0.0.1\r\ncontent-type: application/json\r\n"
            f"content-length: {len(body)}\r\n").encode() + extra + b"\r\n" + body


def test_the_service_over_the_protocol(db_path):
    raw = json.dumps(sim_body()).encode()
    with server(db_path, max_upload_bytes=100_000) as port, \
            socket.create_connection(("127.0.0.1", port)) as s:
        s.settimeout(30)   # a bound on a hang, not a speed claim
        for _ in range(3):   # keep-alive: one connection, several answers
            s.sendall(request("POST", "/api/simulate", raw))
            status, headers, body = read_response(s)
            assert status == 200 and len(json.loads(body)["series"]["t"]) == 1001
            assert "frame-ancestors 'none'" in headers["content-security-policy"]
        s.sendall(request("HEAD", "/api/limits"))          # a head without a body
        status, headers, body = read_response(s, head_only=True)
        assert status in (200, 405) and body == b""
        s.sendall(request("GET", "/api/limits"))           # the connection still answers
        status, _, body = read_response(s)
        assert status == 200 and json.loads(body)["max_upload_bytes"] == 100_000
        # refused while reading, and the connection closed: the 413 is sent before the close
        big = b"x" * 200_000
        s.sendall(request("POST", "/api/simulate", big))
        status, headers, body = read_response(s)
        assert status == 413 and "100000" in json.loads(body)["detail"]
        assert headers.get("connection") == "close"
    with server(db_path) as port, socket.create_connection(("127.0.0.1", port)) as s:
        s.settimeout(30)
        s.sendall(b"GET /api/limits HTTP/1.1\r\nhost: evil.example\r\n\r\n")   # Host check
        status, headers, body = read_response(s)
        assert status == 400 and "evil.example" in json.loads(body)["detail"]
