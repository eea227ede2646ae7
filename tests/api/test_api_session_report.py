"""POST /api/reports/sessions/{id}: a refinement session as the user recorded it, as one HTML
file (issue 24: "Reports: the whole refinement (every round)").

A session on the piston-leak sample's locked hold test: version 0 the paper-4way model,
version 1 with the leak added at the conductance the sample hides. The report lists both
versions with their errors, what version 1 changed (the effect and its conductance, with
its unit), the session's dataset in the provenance, and the model; an unknown session is a
404 and a malformed id a 422, before any work.
"""
from __future__ import annotations

import re

from api_conftest import client, db_path, model  # noqa: F401
from pneucore.data.samples import sample_truth

DATASET = "sample-piston-leak-locked-hold"


def test_the_report_holds_every_version_and_what_each_changed(client):  # noqa: F811
    m0 = model()
    s = client.post("/api/sessions", json={"name": "rig <A>", "model": m0,
                                           "experiments": [{"dataset_id": DATASET}]})
    assert s.status_code == 201, s.text
    sid = s.json()["id"]
    g = sample_truth("piston-leak")["model"]["effects"]["piston_leakage"]["conductance"]
    m1 = dict(m0, effects={"piston_leakage": {"conductance": g}})
    v = client.post(f"/api/sessions/{sid}/versions", json={"model": m1, "added": "piston_leakage",
                                                           "params": {"conductance": g}})
    assert v.status_code == 201, v.text
    versions = v.json()["versions"]

    r = client.post(f"/api/reports/sessions/{sid}")
    assert r.status_code == 200, r.text
    assert r.headers["content-type"].startswith("text/html")
    html = r.text
    assert "Refinement session rig &lt;A&gt;" in html and "<A>" not in html     # the name as text
    # both versions with their overall errors in percent, as the session stored them
    for q in versions:
        assert f"{100 * q['overall']:.3g}" in html or f"{100 * q['overall']:.2f}" in html, q
    assert "What each version changed" in html
    assert re.search(r"effects\.piston_leakage\.conductance</td><td>—</td><td>"
                     + re.escape(f"{g:.4g}") + r"</td><td>kg/\(s Pa\)", html), \
        html[html.find("What each version changed"):][:800]
    assert DATASET in html            # the provenance of the data the last version is compared on
    assert html.count("<svg") >= 1    # the last model against the data, drawn inline


def test_an_unknown_or_malformed_session_is_refused(client):  # noqa: F811
    r = client.post("/api/reports/sessions/0123456789ab")
    assert r.status_code == 404 and "0123456789ab" in r.text
    r = client.post("/api/reports/sessions/bad%20id")
    assert r.status_code == 422 and "session_id" in r.text


def test_a_damaged_version_leaves_the_rest_of_the_report(client, db_path):  # noqa: F811
    # the store gives a damaged version's model as null and keeps the others usable: the
    # report lists it without its changes and compares the last readable model, never a 422
    # blaming the request or a 500
    import sqlite3
    m0 = model()
    s = client.post("/api/sessions", json={"name": "rig", "model": m0,
                                           "experiments": [{"dataset_id": DATASET}]})
    sid = s.json()["id"]
    m1 = dict(m0, effects={"piston_leakage": {"conductance": 1e-10}})
    assert client.post(f"/api/sessions/{sid}/versions", json={"model": m1}).status_code == 201
    with sqlite3.connect(db_path) as db:
        db.execute("UPDATE versions SET model='{' WHERE session=? AND version=1", (sid,))
    r = client.post(f"/api/reports/sessions/{sid}")
    assert r.status_code == 200, r.text
    # the model shown and compared is version 0's, the last readable one: no leak in it
    assert "piston_leakage" not in r.text, r.text[:2000]
