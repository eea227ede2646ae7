"""Fuzzing inside the suite: schemathesis against the app's own OpenAPI document and hostile
mutations of valid requests, on a real uvicorn server on 127.0.0.1 (see ``tests/fuzz_api.py``
for the thorough run by hand). No request may get a 5xx or a response outside its schema, and
nothing stored may break a later read."""
from __future__ import annotations

from api_conftest import live_server
from fuzz_api import FuzzReport, run_mutations, run_schemathesis

#: Examples per operation and mode, and mutated requests: enough to cover every operation's
#: error paths in about a minute here; the thorough run uses 100 and 3000
EXAMPLES = 8
MUTATIONS = 240


def test_no_server_error_and_no_schema_violation(tmp_path):
    report = FuzzReport()
    # max_duration 5 s and 50 runs a study: valid fuzzed simulations and studies stay short
    # (documented settings, GET /api/limits)
    with live_server(tmp_path / "fuzz.sqlite3", max_duration=5.0, max_study_runs=50) as url:
        run_mutations(url, MUTATIONS, report, seed=0)
        run_schemathesis(url, EXAMPLES, report, seed=0)
    assert report.requests > MUTATIONS + 100
    assert report.failures == [], "\n".join(map(str, report.failures[:20]))
    assert report.server_errors == 0
