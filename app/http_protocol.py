"""uvicorn's HTTP/1.1 protocol with one write per response: :class:`CombinedWritesProtocol`.

uvicorn writes a response's status line and headers to the socket as soon as the
application starts the response, and the body in a second write. Each write wakes the
client, which reads the headers and sleeps again until the body comes: on a machine
with few cores the client then takes the CPU from the server in the middle of the
response (measured on 2 cores: about 0.3 ms between the two writes of a 240 kB answer
of ``POST /api/simulate``, and twice the context switches under 20 clients).

:class:`CombinedWritesProtocol` gives uvicorn's protocol a transport that holds what is
written during one turn of the event loop and hands it to the socket at the end of that
turn in one ``writelines`` (one ``writev`` system call): the headers and the body of a
response sent in one go leave together. Nothing waits longer than the current turn of
the loop, so a streamed response is not delayed; closing the connection sends what is
held first. ``python -m app`` runs it (:func:`app.main.main`); with uvicorn directly:
``uvicorn app.main:app --http app.http_protocol:CombinedWritesProtocol``.
"""
from __future__ import annotations

import asyncio

try:   # uvicorn's choice for "auto": httptools when installed, else h11
    from uvicorn.protocols.http.httptools_impl import HttpToolsProtocol as _Base
except ImportError:   # pragma: no cover - httptools is a dependency of uvicorn[standard]
    from uvicorn.protocols.http.h11_impl import H11Protocol as _Base


class CombinedWrites:
    """An asyncio transport whose writes during one turn of the event loop leave as one
    ``writelines`` at the end of that turn; everything else is the wrapped transport's.

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
        self._held = []
        self._flush_scheduled = False

    def write(self, data):
        if not data:
            return
        self._held.append(data)
        if not self._flush_scheduled:
            self._flush_scheduled = True
            self._loop.call_soon(self.flush)

    def writelines(self, chunks):
        for data in chunks:
            self.write(data)

    def flush(self):
        """Hand what is held to the socket now (one ``writelines``)."""
        self._flush_scheduled = False
        if not self._held:
            return
        held, self._held = self._held, []
        if self._transport.is_closing():
            return
        if len(held) == 1:
            self._transport.write(held[0])
        else:
            self._transport.writelines(held)

    def get_write_buffer_size(self):
        return self._transport.get_write_buffer_size() + sum(len(b) for b in self._held)

    def write_eof(self):
        self.flush()
        self._transport.write_eof()

    def close(self):
        self.flush()
        self._transport.close()

    def abort(self):
        self._held = []
        self._transport.abort()

    def __getattr__(self, name):   # everything else: the wrapped transport's
        return getattr(self._transport, name)


class CombinedWritesProtocol(_Base):
    """uvicorn's HTTP/1.1 protocol (httptools, else h11) writing through :class:`CombinedWrites`."""

    def connection_made(self, transport):
        super().connection_made(CombinedWrites(transport, asyncio.get_running_loop()))


#: The protocol as uvicorn's ``http`` setting names it
PROTOCOL = f"{__name__}:CombinedWritesProtocol"
