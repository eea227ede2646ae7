"""The app's refinement sessions are pneucore.analysis.history's refinement history, persisted.

pneucore.analysis.history numbers and labels the versions (``base``, ``+ <effect>``,
``recalibrated: ...``, ``version <n>``); the store keeps them, the REST contract of
/api/sessions unchanged (tests/api/test_api_sessions.py).
"""
from __future__ import annotations

import pytest

from api_conftest import client, db_path, model  # noqa: F401
from app.store import Store
from pneucore.analysis.history import RefinementHistory
from pneucore.description.model import Model
from pneucore.description.presets import model_preset


def _model():
    return Model.from_dict(model_preset("paper-4way"))


class _Comparison:
    errors = {"p_a": 0.02, "x": 0.01}
    overall = 0.0158


def test_history_labels_every_kind_of_version():
    h = RefinementHistory()
    m = _model()
    v0 = h.add(m, _Comparison())
    v1 = h.add(m, ({"p_a": 0.01}, 0.01), added="piston_leakage", params={"conductance": 1e-10})
    v2 = h.add(m, None, recalibrated=[{"path": "jack.moving_mass", "label": "moving mass"}])
    v3 = h.add(m.to_dict(), None, note="edited by hand")
    assert [v.version for v in h.versions] == [0, 1, 2, 3]
    assert [v.label for v in h.versions] == ["base", "+ piston_leakage", "recalibrated: moving mass",
                                             "version 3"]
    assert v0.errors == _Comparison.errors and v0.overall == _Comparison.overall
    assert v1.errors == {"p_a": 0.01} and v1.params == {"conductance": 1e-10}
    # nothing to compare with: no errors, no overall
    assert v2.errors == {} and v2.overall is None
    assert v3.note == "edited by hand" and v3.model == m.to_dict()


def test_store_persists_the_history(tmp_path):
    store = Store(str(tmp_path / "s.sqlite3"))
    m = _model()
    sid = store.create_session("s", [], m, ({"p_a": 0.03}, 0.03))
    leak = Model.from_dict({**m.to_dict(), "effects": {"piston_leakage": {"conductance": 8e-11}}})
    assert store.add_version(sid, leak, ({"p_a": 0.01}, 0.01), "piston_leakage", {"conductance": 8e-11},
                             "fitted") == 1
    assert store.add_version(sid, leak, None) == 2
    # the same steps through pneucore.analysis.history give the same versions
    h = RefinementHistory()
    h.add(m, ({"p_a": 0.03}, 0.03))
    h.add(leak, ({"p_a": 0.01}, 0.01), "piston_leakage", {"conductance": 8e-11}, "fitted")
    h.add(leak, None)
    got = store.session(sid)["versions"]
    keys = ("version", "label", "model", "errors", "overall", "added", "params", "note")
    assert [{k: v[k] for k in keys} for v in got] == [{k: getattr(v, k) for k in keys} for v in h.versions]
    assert all(isinstance(v["created"], float) for v in got)   # Unix epoch [s], as the API documents
    store.close()


def test_the_api_records_versions_through_pneucore_history(client, monkeypatch):
    calls = []
    original = RefinementHistory.add

    def spy(self, *args, **kw):
        v = original(self, *args, **kw)
        calls.append(v.label)
        return v
    monkeypatch.setattr(RefinementHistory, "add", spy)
    s = client.post("/api/sessions", json={"model": model()}).json()
    r = client.post(f"/api/sessions/{s['id']}/versions", json={"model": model()})
    assert r.status_code == 201, r.text[:300]
    assert calls == ["base", "version 1"]
    assert [v["label"] for v in r.json()["versions"]] == calls


@pytest.mark.parametrize("overall", [float("nan"), float("inf")])
def test_a_non_finite_overall_is_stored_as_null(tmp_path, overall):
    store = Store(str(tmp_path / "s.sqlite3"))
    sid = store.create_session("s", [], _model(), ({}, overall))
    assert store.session(sid)["versions"][0]["overall"] is None
    store.close()


def test_a_damaged_version_row_does_not_stop_the_next_version(tmp_path):
    store = Store(str(tmp_path / "s.sqlite3"))
    sid = store.create_session("s", [], _model(), None)
    with store._lock:   # an older or damaged row: text where the time and the model belong
        store._db.execute("UPDATE versions SET created='yesterday', model='{not json' WHERE session=?",
                          (sid,))
    assert store.add_version(sid, _model(), None, note="after the damage") == 1
    v = store.session(sid)["versions"][1]
    assert v["label"] == "version 1" and v["note"] == "after the damage"
    store.close()
