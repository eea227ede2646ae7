"""uvicorn's HTTP/1.1 protocol with one write per response: :class:`CombinedWritesProtocol`.

uvicorn writes a response's status line and headers to the socket as soon as the
application starts the response, and the body in a second write. Each write wakes the
client, which reads the headers and sleeps again until the body comes: two system calls
and two wake-ups of the client for every answer, where one does.

:class:`CombinedWritesProtocol` gives uvicorn's protocol a transport
(:class:`CombinedWrites`) that holds a write until the next one, and hands both to the
socket in one write: the head of a response leaves with the first part of its body. What is held leaves at the latest when the response is
complete, when the connection closes, or at the end of the event loop's turn (a head
whose body is slow to come), so nothing waits behind other requests. ``python -m app``
runs it (:func:`app.main.main`); with uvicorn directly:
``uvicorn app.main:app --http app.http_protocol:CombinedWritesProtocol``.
"""
from __future__ import annotations

import asyncio

from .config import Limits

try:   # uvicorn's choice for "auto": httptools when installed, else h11
    from uvicorn.protocols.http.httptools_impl import HttpToolsProtocol as _Base
except ImportError:   # pragma: no cover - httptools is a dependency of uvicorn[standard]
    from uvicorn.protocols.http.h11_impl import H11Protocol as _Base


class CombinedWrites:
    """An asyncio transport that holds a write until the next one and sends both in one
    write; what is held leaves at :meth:`flush` (the response is complete), at
    :meth:`close`, or at the end of the loop's turn. Everything else is the wrapped
    transport's.

    Parameters
    ----------
    transport : asyncio.Transport
        The connection's transport
    loop : asyncio.AbstractEventLoop
        The loop that runs the connection
    """

    def __init__(self, transport, loop):
        self._transport = transport
        self._loop = loop
        self._held = None
        self._flush_scheduled = False

    def write(self, data):
        if not data:
            return
        if self._held is None:
            self._held = data if isinstance(data, bytes) else bytes(data)   # not changed later
            if not self._flush_scheduled:
                self._flush_scheduled = True
                self._loop.call_soon(self._end_of_turn)
            return
        held, self._held = self._held, None
        if not self._transport.is_closing():
            # one buffer (a copy: 20 us for 240 kB): uvloop sends a write at once, where
            # it queues a writelines to the end of the loop's turn, behind other requests
            self._transport.write(held + data)

    def writelines(self, chunks):
        for data in chunks:
            self.write(data)

    def flush(self):
        """Hand what is held to the socket now."""
        if self._held is not None:
            held, self._held = self._held, None
            if not self._transport.is_closing():
                self._transport.write(held)

    def _end_of_turn(self):
        self._flush_scheduled = False
        self.flush()

    def get_write_buffer_size(self):
        return self._transport.get_write_buffer_size() + (len(self._held) if self._held else 0)

    def write_eof(self):
        self.flush()
        self._transport.write_eof()

    def close(self):
        self.flush()
        self._transport.close()

    def abort(self):
        self._held = None
        self._transport.abort()

    def __getattr__(self, name):   # everything else: the wrapped transport's
        return getattr(self._transport, name)


#: Largest request head [bytes] and time to send it [s] (one source: :class:`app.config.Limits`)
MAX_HEADER_BYTES = Limits.max_header_bytes
HEADER_TIMEOUT = Limits.header_timeout

_TOO_LARGE = (b"HTTP/1.1 431 Request Header Fields Too Large\r\ncontent-type: application/json\r\n"
              b"connection: close\r\ncontent-length: %d\r\n\r\n%s")


class CombinedWritesProtocol(_Base):
    """uvicorn's HTTP/1.1 protocol (httptools, else h11) writing through :class:`CombinedWrites`,
    with the limits uvicorn lacks: a request head larger than :data:`MAX_HEADER_BYTES` is
    answered 431 and the connection closed; a head not complete :data:`HEADER_TIMEOUT` seconds
    after the connection opened or the previous answer was sent (a slow-header client) closes
    the connection."""

    def connection_made(self, transport):
        super().connection_made(CombinedWrites(transport, asyncio.get_running_loop()))
        self._head_bytes, self._in_head, self._head_timer = 0, True, None
        self._arm_head_timer(HEADER_TIMEOUT)

    def _arm_head_timer(self, delay):
        if self._head_timer is not None:
            self._head_timer.cancel()
        self._head_timer = asyncio.get_running_loop().call_later(delay, self._head_timeout)

    def _head_timeout(self):
        self._head_timer = None
        if self._in_head and not self.transport.is_closing():
            self.transport.close()

    def data_received(self, data):
        super().data_received(data)
        if self._in_head:
            self._head_bytes += len(data)
            if self._head_bytes > MAX_HEADER_BYTES and not self.transport.is_closing():
                body = (b'{"detail": "request head larger than max_header_bytes = %d bytes '
                        b'(GET /api/limits)"}' % MAX_HEADER_BYTES)
                self.transport.write(_TOO_LARGE % (len(body), body))
                self.transport.close()

    def on_headers_complete(self):
        self._in_head = False
        if self._head_timer is not None:
            self._head_timer.cancel()
            self._head_timer = None
        super().on_headers_complete()

    def on_response_complete(self):
        self.transport.flush()   # a response without a body (HEAD, 204, 304) has its head held
        super().on_response_complete()
        # the next request's head: uvicorn's keep-alive timeout closes an idle connection first
        self._head_bytes, self._in_head = 0, True
        self._arm_head_timer(HEADER_TIMEOUT + self.config.timeout_keep_alive)

    def connection_lost(self, exc):
        if getattr(self, "_head_timer", None) is not None:
            self._head_timer.cancel()
        super().connection_lost(exc)


#: The protocol as uvicorn's ``http`` setting names it
PROTOCOL = f"{__name__}:CombinedWritesProtocol"
