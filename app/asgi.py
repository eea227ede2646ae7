"""Small pieces shared by the service's ASGI middlewares (the body limit, the catch-all 500)."""


class TrackedSend:
    """An ASGI ``send`` that remembers whether the answer has started.

    A middleware that turns an exception into its own answer may do so only while nothing has
    been sent: once ``http.response.start`` went out, the answer is incomplete and the
    exception must reach the server, which closes the connection.

    Parameters
    ----------
    send : callable
        The server's ASGI ``send``
    """

    def __init__(self, send):
        self.send = send
        self.started = False

    async def __call__(self, message):
        if message["type"] == "http.response.start":
            self.started = True
        await self.send(message)


async def send_json(send, status: int, body: bytes, close: bool = False):
    """Send a whole JSON answer through ``send``.

    Parameters
    ----------
    send : callable
        The server's ASGI ``send``
    status : int
        HTTP status code [-]
    body : bytes
        The JSON body, already encoded
    close : bool
        Ask the client to close the connection (a body left unread)
    """
    headers = [(b"content-type", b"application/json"),
               (b"content-length", str(len(body)).encode())]
    if close:
        headers.append((b"connection", b"close"))
    await send({"type": "http.response.start", "status": status, "headers": headers})
    await send({"type": "http.response.body", "body": body})
