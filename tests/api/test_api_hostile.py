"""Hostile load and faults (issue 30): exports a spreadsheet cannot execute, a memory budget per
request, bounded form fields and names, server limits, a full disk, a bounded synchronous pool."""
from __future__ import annotations

import csv
import io

import pytest

from api_conftest import (client, db_path, inline_experiment, model, small_csv)  # noqa: F401
from pneucore.data.export import FORMULA_STARTS, simulation_csv, spreadsheet_safe

#: Names a spreadsheet would run as formulas (OWASP's CSV injection examples)
FORMULA_NAMES = ["=1+2", "@SUM(1+1)*cmd|' /C calc'!A0", "+1", "-2+3", "\tx", "\r=1"]


def _text_cells_are_safe(text):
    """Every cell of a CSV text that is not a number starts with no formula character."""
    for row in csv.reader(io.StringIO(text)):
        for cell in row:
            try:
                float(cell)
                continue   # numbers untouched: -1.5 stays a number
            except ValueError:
                pass
            assert not cell.startswith(FORMULA_STARTS), (cell, row)


# ------------------------------------------------------------------ (4) formula injection
@pytest.mark.parametrize("name", FORMULA_NAMES)
def test_spreadsheet_safe_quotes_formula_cells(name):
    assert spreadsheet_safe(name) == "'" + name
    assert spreadsheet_safe("run 1") == "run 1"


def test_simulation_csv_text_cells_are_neutralised_numbers_untouched():
    text = simulation_csv({"series": {"t": [0.0, 1.0], "x": [-1.5, 2.0], "mode": ["=cmd", "stick"],
                                      "=bad": [1.0, -2.0]},
                           "units": {"t": "s", "x": "m", "mode": "-", "=bad": "-"}})
    _text_cells_are_safe(text)
    rows = list(csv.reader(io.StringIO(text)))
    assert rows[2][1] == "-1.5" and rows[2][2] == "'=cmd"


@pytest.mark.parametrize("name", FORMULA_NAMES[:2])
def test_comparison_csv_neutralises_experiment_and_dataset_names(client, name):
    exp = inline_experiment("clean", "free-pulses")
    exp["name"] = name
    r = client.post("/api/compare", json={"model": model(), "experiments": [exp]},
                    headers={"accept": "text/csv"})
    assert r.status_code == 200, r.text[:500]
    _text_cells_are_safe(r.text)
    rows = list(csv.reader(io.StringIO(r.text)))
    assert rows[2][0] == "'" + name and float(rows[2][1]) == pytest.approx(float(rows[2][1]))
    # a stored dataset named so
    up = client.post("/api/datasets", files={"file": ("a.csv", small_csv(40), "text/csv")},
                     data={"name": name})
    assert up.status_code in (200, 201), up.text
    r = client.post("/api/compare", json={"model": model(), "experiments": [
        {"dataset_id": up.json()["id"]}]}, headers={"accept": "text/csv"})
    assert r.status_code == 200, r.text[:500]
    _text_cells_are_safe(r.text)


def test_study_runs_csv_neutralises_error_messages(monkeypatch):
    """A failed run's message (text the solver or a user law wrote) cannot start a formula."""
    from types import SimpleNamespace

    import numpy as np

    from pneucore.study import results
    block = SimpleNamespace(indices=np.array([0, 1]), params=np.array([[-1.5], [2.0]]),
                            metrics=np.array([[np.nan], [3.0]]), errors=["=HYPERLINK(1)", None])
    monkeypatch.setattr(results, "_stored_runs", lambda *a: (["supply.pressure"], ["t95"], block))
    text = "".join(results.runs_csv("unused", "s1"))
    _text_cells_are_safe(text)
    rows = list(csv.reader(io.StringIO(text)))
    assert rows[1][1] == "-1.5" and rows[1][-1] == "'=HYPERLINK(1)"


# ------------------------------------------------------------------ (1) a memory budget per request
def _npz(**arrays):
    import numpy as np
    buf = io.BytesIO()
    np.savez(buf, **arrays)
    return buf.getvalue()


def test_the_memory_budget_is_a_limit_and_refuses_an_archive_before_reading(db_path):
    import numpy as np

    from api_conftest import api
    data = _npz(t=np.arange(50_000) * 1e-4, u=np.ones(50_000), p_a=np.full(50_000, 2e5))
    with api(db_path, max_request_memory=1_000_000) as c:
        assert c.get("/api/limits").json()["max_request_memory"] == 1_000_000
        r = c.post("/api/datasets", files={"file": ("a.npz", data, "application/x-npz")})
        assert r.status_code == 422 and "max_request_memory" in r.text, r.text
    with api(db_path) as c:
        r = c.post("/api/datasets", files={"file": ("a.npz", data, "application/x-npz")})
        assert r.status_code == 201, r.text


# ------------------------------------------------------------------ (6) fields, names, counts
def _up(c, **fields):
    return c.post("/api/datasets", files={"file": ("a.csv", small_csv(), "text/csv")},
                  data={k: str(v) for k, v in fields.items()})


@pytest.mark.parametrize("key", ["columns", "scenario"])
def test_deep_or_long_json_form_fields_are_422_naming_the_field(client, key):
    from api_conftest import assert_field_error
    assert_field_error(_up(client, **{key: "[" * 5000 + "]" * 5000}), key, msg_contains="max_json_depth")
    assert_field_error(_up(client, **{key: '{"a": "' + "x" * 300_000 + '"}'}), key,
                       msg_contains="max_form_field_bytes")


@pytest.mark.parametrize("name", ["x" * 201, "a\nb", "a\x1b[31mb", "a\tb"])
def test_names_are_bounded_and_free_of_control_characters(client, name):
    from api_conftest import assert_field_error, inline_experiment
    assert_field_error(_up(client, name=name), "name")
    r = client.post("/api/datasets", json={"name": name, "measurement": inline_experiment(
        "clean", "free-pulses")["measurement"]})
    assert r.status_code == 422 and r.json()["detail"][0]["field"] == "name", r.text[:300]
    r = client.post("/api/sessions", json={"name": name, "model": model()})
    assert r.status_code == 422 and r.json()["detail"][0]["field"] == "name", r.text[:300]
    assert _up(client, name="ok name").status_code == 201


@pytest.mark.parametrize("nfev", [-1, 0, 10_000])
def test_max_nfev_out_of_range_is_422(client, nfev):
    r = client.post("/api/calibrate", json={"model": model(), "experiments": [
        {"dataset_id": "sample-clean-free-pulses"}], "parameters": {"friction.extend.fc0": {}},
        "max_nfev": nfev})
    assert r.status_code == 422 and r.json()["detail"][0]["field"] == "max_nfev", r.text[:300]


def test_a_token_in_the_query_never_reaches_the_access_log():
    """uvicorn's access line is written from the request's scope: the guard redacts the token in
    it before anything answers (the login's 303, a refusal, any route)."""
    import asyncio

    from app.security import Guard
    seen = {}

    async def inner(scope, receive, send):
        seen["inner"] = scope["query_string"]

    async def send(message):
        pass
    for path, query in (("/", b"token=s3cret"), ("/api/limits", b"token=s3cret&x=1")):
        scope = {"type": "http", "method": "GET", "path": path, "query_string": query,
                 "headers": [(b"host", b"127.0.0.1")], "scheme": "http"}
        asyncio.run(Guard(inner, ["127.0.0.1"], token="s3cret")(scope, None, send))
        assert b"s3cret" not in scope["query_string"]


# ------------------------------------------------------------------ (3) server limits
@pytest.fixture
def protocol_server(db_path, monkeypatch):
    """``python -m app``'s protocol on a live uvicorn (in a thread), the head timeout 1 s."""
    import socket
    import threading
    import time

    import uvicorn

    from api_conftest import make_settings
    from app import http_protocol
    from app.main import create_app
    monkeypatch.setattr(http_protocol, "HEADER_TIMEOUT", 1.0)
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        port = s.getsockname()[1]
    server = uvicorn.Server(uvicorn.Config(create_app(make_settings(db_path)), host="127.0.0.1",
                                           port=port, log_level="warning",
                                           http=http_protocol.CombinedWritesProtocol))
    th = threading.Thread(target=server.run, daemon=True)
    th.start()
    t0 = time.monotonic()
    while not server.started:
        assert time.monotonic() - t0 < 60 and th.is_alive()   # a bound on a hang
        time.sleep(0.02)
    yield port
    server.should_exit = True
    th.join(timeout=30)


def _recv_all(sock, budget):
    import time
    sock.settimeout(budget)
    out, t0 = b"", time.monotonic()
    while time.monotonic() - t0 < budget:
        try:
            chunk = sock.recv(65536)
        except (TimeoutError, OSError):
            break
        if not chunk:
            return out, True   # closed by the server
        out += chunk
    return out, False


def test_a_slow_header_client_is_cut_off(protocol_server):
    import socket
    with socket.create_connection(("127.0.0.1", protocol_server)) as s:
        s.sendall(b"GET /api/limits HTTP/1.1\r\nHost: 127.0.0.1\r\nX-Slow: 1\r\n")
        _, closed = _recv_all(s, 20.0)   # generous: the cut comes after 1 s
        assert closed
    # a client that sends its head is answered, and kept alive past the head timeout
    with socket.create_connection(("127.0.0.1", protocol_server)) as s:
        s.sendall(b"GET /api/limits HTTP/1.1\r\nHost: 127.0.0.1\r\n\r\n")
        s.settimeout(20)
        assert s.recv(65536).startswith(b"HTTP/1.1 200")


def test_an_oversized_header_is_431(protocol_server):
    import socket

    from app.config import Limits
    with socket.create_connection(("127.0.0.1", protocol_server)) as s:
        s.sendall(b"GET /api/limits HTTP/1.1\r\nHost: 127.0.0.1\r\nX-Big: ")
        try:
            s.sendall(b"a" * (Limits.max_header_bytes + 1024))
        except OSError:
            pass   # the server may close while we still write
        out, closed = _recv_all(s, 20.0)
        assert out.startswith(b"HTTP/1.1 431") and b"max_header_bytes" in out, out[:200]
