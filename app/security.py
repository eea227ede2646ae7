"""Safe defaults for a single-user tool on localhost, and the settings for a shared server.

One ASGI middleware, :class:`Guard`, checks every HTTP request in this order:

1. **Host** (against DNS rebinding): the ``Host`` header must name one of
   ``Settings.allowed_hosts`` (``$PNEUCORE_ALLOWED_HOSTS``, comma-separated;
   default ``localhost,127.0.0.1,::1``); otherwise 400.
2. **Origin** (against cross-site requests, which a multipart upload makes
   without a CORS preflight): a state-changing request (POST, PUT, PATCH,
   DELETE) that carries an ``Origin`` header must come from this very server
   (the scheme and the ``Host`` it was sent to); otherwise 403. Programs that
   send no ``Origin`` (curl, scripts) are not browsers and pass.
3. **Token** (for a shared machine): when ``Settings.token`` (``$PNEUCORE_TOKEN``)
   is set, every request needs it, as ``Authorization: Bearer <token>`` or as the
   ``pneucore_token`` cookie; otherwise 401. The page gets the cookie by being
   opened once as ``http://host:port/?token=<token>``: the server sets the cookie
   (HttpOnly, SameSite=Strict) and redirects to ``/`` so the token leaves the
   address bar; the page's own requests then carry it.

Every response carries a strict Content-Security-Policy (scripts only from this
server, no inline script, no plug-ins, not framed; the documentation site's pages a policy
of their own allowing their inline scripts by hash, :mod:`app.docs_site`) and ``X-Content-Type-Options:
nosniff``; the page inserts user-supplied text only as text.
"""
from __future__ import annotations

import hmac
from urllib.parse import parse_qs, unquote_plus, urlsplit

import orjson

#: Content-Security-Policy of every response. Scripts and connections only to this server;
#: styles also inline (Plotly positions its SVG with style attributes), images also data:
#: and blob: (Plotly's image export)
CSP = ("default-src 'self'; script-src 'self'; style-src 'self' 'unsafe-inline'; "
       "img-src 'self' data: blob:; font-src 'self'; connect-src 'self'; object-src 'none'; "
       "base-uri 'none'; form-action 'self'; frame-ancestors 'none'")

COOKIE = "pneucore_token"
UNSAFE_METHODS = frozenset({"POST", "PUT", "PATCH", "DELETE"})
SECURITY_HEADERS = [(b"content-security-policy", CSP.encode()),
                    (b"x-content-type-options", b"nosniff"),
                    (b"referrer-policy", b"no-referrer"),
                    (b"x-frame-options", b"DENY")]


def host_name(host: str) -> str:
    """The host name of a ``Host`` header value, without port (``[::1]:8000`` -> ``::1``)."""
    host = host.strip().lower()
    if host.startswith("["):
        return host[1:host.find("]")] if "]" in host else host
    if host.count(":") == 1:
        return host.split(":", 1)[0]
    return host


def redact_token(query_string: bytes) -> bytes:
    """``query_string`` with the value of every ``token`` parameter replaced by ``redacted``;
    every other parameter, its order and its encoding kept as sent.

    Parameters
    ----------
    query_string : bytes
        The raw query string of a request (``a=1&token=s3cret&b=2``)

    Returns
    -------
    bytes
        ``a=1&token=redacted&b=2``
    """
    parts = query_string.split(b"&")
    for i, part in enumerate(parts):
        key = unquote_plus(part.split(b"=", 1)[0].decode("latin-1"))
        if key == "token":
            parts[i] = b"token=redacted"
    return b"&".join(parts)


class Guard:
    """ASGI middleware: Host, Origin and token checks, and the security headers."""

    def __init__(self, app, allowed_hosts, token=None):
        self.app = app
        self.any_host = "*" in allowed_hosts
        self.allowed = {host_name(h) for h in allowed_hosts if h.strip()}
        self.token = token or None

    async def __call__(self, scope, receive, send):
        if scope["type"] != "http":
            return await self.app(scope, receive, send)
        headers = {}
        for k, v in scope.get("headers", ()):
            headers.setdefault(k.decode("latin-1").lower(), v.decode("latin-1"))
        host = headers.get("host", "")
        if not self.any_host and host_name(host) not in self.allowed:
            return await _deny(send, 400, f"host {host!r} is not allowed; set PNEUCORE_ALLOWED_HOSTS "
                                          f"to serve other names")
        origin = headers.get("origin")
        if scope["method"] in UNSAFE_METHODS and origin is not None:
            o = urlsplit(origin)
            scheme = scope.get("scheme", "http")
            if origin == "null" or o.scheme != scheme or (o.netloc or "").lower() != host.lower():
                return await _deny(send, 403, f"cross-origin {scope['method']} from {origin!r} refused")
        query = parse_qs(scope.get("query_string", b"").decode("latin-1"))
        if "token" in query:
            # the server's access log writes the request line from this very scope when the
            # answer starts: the secret never reaches a log line, the rest of the query does
            scope["query_string"] = redact_token(scope["query_string"])
        if self.token is not None:
            if scope["path"] == "/" and scope["method"] == "GET" and "token" in query:
                return await self._login(send, query["token"][0])
            if not self._authorised(headers):
                return await _deny(send, 401, "this server requires a token: send "
                                              "'Authorization: Bearer <token>', or open the page once "
                                              "as /?token=<token>",
                                   [(b"www-authenticate", b'Bearer realm="pneucore"')])

        async def send_with_headers(message):
            if message["type"] == "http.response.start":
                headers = list(message.get("headers", []))
                # a response with a policy of its own (the documentation site's pages,
                # app.docs_site) keeps it alone: a second policy would be enforced besides
                own = any(k.lower() == b"content-security-policy" for k, _ in headers)
                message = {**message, "headers": headers + (SECURITY_HEADERS[1:] if own
                                                            else SECURITY_HEADERS)}
            await send(message)
        await self.app(scope, receive, send_with_headers)

    def _valid(self, given):
        return given is not None and hmac.compare_digest(given.encode(), self.token.encode())

    def _authorised(self, headers):
        auth = headers.get("authorization", "")
        if auth[:7].lower() == "bearer " and self._valid(auth[7:].strip()):
            return True
        for part in headers.get("cookie", "").split(";"):
            name, _, value = part.strip().partition("=")
            if name == COOKIE and self._valid(value):
                return True
        return False

    async def _login(self, send, given):
        if not self._valid(given):
            return await _deny(send, 401, "wrong token")
        cookie = f"{COOKIE}={self.token}; Path=/; HttpOnly; SameSite=Strict"
        await send({"type": "http.response.start", "status": 303,
                    "headers": [(b"location", b"/"), (b"set-cookie", cookie.encode()),
                                (b"content-length", b"0")] + SECURITY_HEADERS})
        await send({"type": "http.response.body", "body": b""})


async def _deny(send, status, detail, extra=()):
    body = orjson.dumps({"detail": detail})
    await send({"type": "http.response.start", "status": status,
                "headers": [(b"content-type", b"application/json"),
                            (b"content-length", str(len(body)).encode())] + list(extra)
                + SECURITY_HEADERS})
    await send({"type": "http.response.body", "body": body})
