"""Fuzzing the REST API: schemathesis from the OpenAPI document, and mutations of valid requests.

Shared by the in-suite test (``tests/api/test_api_fuzz.py``, a few examples per
operation) and the thorough run by hand::

    python tests/fuzz_api.py --examples 200 --mutations 3000

which starts a real uvicorn server on 127.0.0.1 with a temporary database and
prints the number of requests and every server error or schema violation.
Schemathesis alone rarely produces a valid actuator model, so the second part
takes valid requests (simulate, compare, calibrate, diagnose, sessions,
datasets) and replaces one field anywhere in them with hostile JSON (NaN,
huge numbers, wrong types, attribute-like paths such as ``jack.area_a`` or
``supply.pressure.real``): that is how the deep 500s were found.
"""
from __future__ import annotations

import copy
import json
import random
import re
from dataclasses import dataclass, field

import httpx

#: Operations left out of a run (none by default; the command line can name some)
EXCLUDED_PATHS = ()


@dataclass
class FuzzReport:
    requests: int = 0
    status: dict = field(default_factory=dict)
    failures: list = field(default_factory=list)   # (what, method, path, detail)

    def add(self, status):
        self.requests += 1
        self.status[status] = self.status.get(status, 0) + 1

    @property
    def server_errors(self):
        return sum(n for s, n in self.status.items() if s >= 500)


def run_schemathesis(base_url, examples, report, seed=0, excluded=EXCLUDED_PATHS):
    """Positive and negative cases of every operation; checks: no 5xx, responses match the schema."""
    import schemathesis
    from hypothesis import HealthCheck, Phase, given, settings
    from hypothesis.errors import Unsatisfiable
    from schemathesis import GenerationMode
    from schemathesis.checks import not_a_server_error
    from schemathesis.specs.openapi.checks import response_schema_conformance

    schema = schemathesis.openapi.from_url(base_url + "/openapi.json")
    checks = [not_a_server_error, response_schema_conformance]
    for result in schema.get_all_operations():
        op = result.ok()
        if op.path.startswith(tuple(excluded)):
            continue
        for mode in (GenerationMode.POSITIVE, GenerationMode.NEGATIVE):
            @given(case=op.as_strategy(generation_mode=mode))
            @settings(max_examples=examples, deadline=None, database=None, derandomize=seed == 0,
                      suppress_health_check=list(HealthCheck), phases=[Phase.explicit, Phase.generate])
            def one(case):
                try:
                    resp = case.call(base_url=base_url, timeout=120)
                except Exception as exc:   # a transport failure counts as a server failure
                    report.add(599)
                    report.failures.append(("transport", case.method, case.path, repr(exc)[:300]))
                    return
                report.add(resp.status_code)
                try:
                    case.validate_response(resp, checks=checks)
                except (Exception, BaseExceptionGroup) as exc:   # schemathesis' FailureGroup
                    report.failures.append(("schemathesis", case.method, case.formatted_path,
                                            f"{resp.status_code}: {str(exc)[:400]}"))
            try:
                one()
            except Unsatisfiable:   # nothing to negate (an operation without inputs)
                pass


# ------------------------------------------------------------------ mutations of valid requests
HOSTILE = [None, True, 0, -1, 1e308, -1e308, 1e-320, float("nan"), float("inf"), 10**30, "", "x",
           "nan", "<script>alert(1)</script>", [], {}, [1, 2], {"a": 1}, [[0, 0]], "jack.area_a",
           "supply.pressure.real", "friction.extend.__class__", "effects.nope.x", "valve.ports.P-A.C",
           "valve.ports.X.b", "jack", "piston_leakage", "warp_drive", 0.5, 1e-9, 3.0, -0.0]


def _leaves(obj, path=()):
    """Every (path, value) in a JSON document, containers included."""
    yield path, obj
    if isinstance(obj, dict):
        for k, v in obj.items():
            yield from _leaves(v, path + (k,))
    elif isinstance(obj, list):
        for i, v in enumerate(obj[:6]):   # long arrays: their first entries stand for the rest
            yield from _leaves(v, path + (i,))


def _mutate(doc, rng):
    """One hostile change: a value replaced, a key deleted, renamed or added.

    Shallow fields (request options, parameter paths, effect names) are picked
    more often than the leaves of the model, which are many but alike.
    """
    doc = copy.deepcopy(doc)
    paths = [p for p, _ in _leaves(doc) if p]
    shallow = [p for p in paths if len(p) <= 2]
    p = rng.choice(shallow if rng.random() < 0.4 else paths)
    parent = doc
    for k in p[:-1]:
        parent = parent[k]
    roll = rng.random()
    names = [h for h in HOSTILE if isinstance(h, str)]
    if roll < 0.1 and isinstance(parent, dict):
        del parent[p[-1]]
    elif roll < 0.25 and isinstance(parent, dict):   # a key renamed: parameter paths, effects
        parent[rng.choice(names)] = parent.pop(p[-1])
    elif roll < 0.35 and isinstance(parent, dict):
        parent[rng.choice(names)] = rng.choice(HOSTILE)
    else:
        parent[p[-1]] = rng.choice(HOSTILE)
    return doc


def templates(short=True):
    """Valid requests ``(method, path, body)``: each endpoint that takes a JSON body."""
    from pneucore import model_preset, scenario_preset
    m = model_preset("paper-4way")
    s = scenario_preset("paper-fig10-pulses")
    if short:
        s["duration"] = 0.2
    exps = [{"dataset_id": "sample-piston-leak-locked-hold"}]
    meas = {"t": [i * 1e-3 for i in range(30)], "u": [0.0] * 10 + [1.0] * 20,
            "p_a": [2e5 + 1e3 * i for i in range(30)]}
    # a time column built as n * dt: its last sample lies a rounding past the duration typed
    # (70 * 0.01 = 0.7000000000000001 > 0.7), one at the duration and one clearly past it
    t_edge = [i * 0.01 for i in range(71)]
    edge = {"name": "edge", "scenario": {"locked": True, "x0": 0.1, "duration": 0.7},
            "measurement": {"t": t_edge, "u": [0.0] * 30 + [1.0] * 41,
                            "p_a": [2e5 + 1e3 * i for i in range(71)]}}
    past = copy.deepcopy(edge)
    past["measurement"]["t"][-1] = 0.7 + 1e-9
    at = copy.deepcopy(edge)
    at["measurement"]["t"][-1] = 0.7
    return [
        ("POST", "/api/simulate", {"model": m, "scenario": s}),
        ("POST", "/api/compare", {"model": m, "experiments": [edge, at, past], "residuals": False}),
        ("POST", "/api/compare", {"model": m, "experiments": exps, "residuals": False}),
        ("POST", "/api/calibrate", {"model": m, "experiments": exps, "max_nfev": 2,
                                    "parameters": {"heat.coefficient": {"min": 5, "max": 80}}}),
        ("POST", "/api/diagnose", {"model": m, "experiments": exps, "candidates": ["piston_leakage"],
                                   "uncertain": ["heat.coefficient"]}),
        ("POST", "/api/jobs/calibrate", {"model": m, "experiments": exps, "max_nfev": 2,
                                         "parameters": {"jack.moving_mass": {}}}),
        ("POST", "/api/sessions", {"name": "s", "model": m, "experiments": []}),
        ("POST", "/api/datasets", {"name": "d", "scenario": {"locked": True, "x0": 0.1},
                                   "measurement": meas}),
        ("POST", "/api/studies", {"model": m, "scenario": s, "samples": 4, "seed": 1, "workers": 0,
                                  "parameters": {"friction.extend.fc0": {"distribution": "uniform",
                                                                         "min": 4, "max": 16}}}),
    ]


@dataclass
class _Dropped:
    """A request the server dropped (connection reset, timeout): counted as 599."""
    text: str
    status_code: int = 599


#: ``Accept`` headers sent with the mutated requests: each answer form, and malformed ones
ACCEPTS = [None, "application/json", "text/csv", "application/x-npz", "*/*",
           "application/x-npz;q=0.5, text/csv;q=0.9", "application/x-npz;q=nan", "text/csv;q=-1",
           ";;,,;q=", "application/x-npz;q=" + "9" * 400, ",".join(["text/csv"] * 500)]


def _send(c, method, path, text, accept=None):
    """One request; a transport error is retried once on a fresh connection before it counts.

    A kept-alive connection that the server closes after its idle timeout (uvicorn: 5 s) just
    as the client reuses it is reset without any fault of the server's; a server that really
    dropped the request (a crash, a hang) fails the retry too and is counted as 599."""
    for attempt in (0, 1):
        try:
            headers = {"content-type": "application/json"}
            if accept is not None:
                headers["accept"] = accept
            return c.request(method, path, content=text, headers=headers)
        except httpx.TransportError as exc:
            if attempt:
                return _Dropped(f"transport error (twice): {exc!r}")


#: A numpy repr in a message (``np.float64(0.0)``, ``array([...])``): the user reads the
#: number, not numpy's spelling of it (issue 28)
NUMPY_REPR = re.compile(r"\bnp\.\w+\(|\barray\(\[|\bnp\.(True|False)_\b")


def _numpy_repr(r):
    """The first numpy repr in an error answer's text, or None."""
    if r.status_code < 400:
        return None
    m = NUMPY_REPR.search(r.text)
    return r.text[max(m.start() - 120, 0):m.end() + 60] if m else None


def run_mutations(base_url, n, report, seed=0, excluded=EXCLUDED_PATHS):
    """``n`` requests, each a valid template with one field replaced by hostile JSON."""
    rng = random.Random(seed)
    tmpl = [t for t in templates() if not t[1].startswith(tuple(excluded))]
    with httpx.Client(base_url=base_url, timeout=120) as c:
        sid = c.post("/api/sessions", json={"model": tmpl[0][2]["model"]}).json()["id"]
        tmpl.append(("POST", f"/api/sessions/{sid}/versions",
                     {"model": tmpl[0][2]["model"], "added": "piston_leakage",
                      "params": {"conductance": 8e-11}, "note": ""}))
        # every hostile name in every field that names something (parameter paths, effects)
        names = [h for h in HOSTILE if isinstance(h, str)]
        sweep = []
        for method, path, body in tmpl:
            for name in names:
                if "parameters" in body:
                    sweep.append((method, path, {**body, "parameters": {name: {}}}))
                if "uncertain" in body:
                    sweep.append((method, path, {**body, "uncertain": [name]}))
                if "candidates" in body:
                    sweep.append((method, path, {**body, "candidates": [name]}))
        for method, path, doc in sweep:
            r = _send(c, method, path, json.dumps(doc))
            report.add(r.status_code)
            if r.status_code >= 500:
                report.failures.append(("names", method, path, f"{r.status_code} {r.text[:300]} <- "
                                                               f"{json.dumps(doc)[-200:]}"))
            elif _numpy_repr(r):
                report.failures.append(("numpy repr", method, path, f"{r.status_code} {_numpy_repr(r)}"))
        for i in range(n):
            method, path, body = tmpl[i % len(tmpl)]
            doc = _mutate(body, rng)
            text = json.dumps(doc)   # NaN/Infinity tokens: what a careless client sends
            r = _send(c, method, path, text, rng.choice(ACCEPTS))
            report.add(r.status_code)
            if r.status_code >= 500:
                report.failures.append(("mutation", method, path, f"{r.status_code} {r.text[:300]} "
                                                                  f"<- {text[:300]}"))
            elif _numpy_repr(r):
                report.failures.append(("numpy repr", method, path, f"{r.status_code} {_numpy_repr(r)} "
                                                                    f"<- {text[:300]}"))
        for path in ("/api/datasets", "/api/sessions"):   # nothing stored can break a read
            r = c.get(path)
            report.add(r.status_code)
            if r.status_code != 200:
                report.failures.append(("read-back", "GET", path, f"{r.status_code} {r.text[:300]}"))


def main():
    import argparse
    import sys
    import tempfile
    from pathlib import Path
    sys.path.insert(0, str(Path(__file__).resolve().parent))
    from api_conftest import live_server
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--examples", type=int, default=100, help="schemathesis examples per operation and mode")
    p.add_argument("--mutations", type=int, default=2000)
    p.add_argument("--seed", type=int, default=1)
    p.add_argument("--url", help="fuzz a running server instead (e.g. the original code)")
    p.add_argument("--exclude", nargs="*", default=[], help="path prefixes to leave out")
    a = p.parse_args()
    excluded = tuple(a.exclude) or EXCLUDED_PATHS
    report = FuzzReport()

    def go(url):
        run_mutations(url, a.mutations, report, a.seed, excluded)
        run_schemathesis(url, a.examples, report, a.seed, excluded)
    if a.url:
        go(a.url)
    else:
        with tempfile.TemporaryDirectory() as tmp, live_server(Path(tmp) / "fuzz.sqlite3", max_duration=5.0,
                                                                max_study_runs=50) as url:
            go(url)
    print(f"requests: {report.requests}; status codes: {dict(sorted(report.status.items()))}; "
          f"server errors: {report.server_errors}; failures: {len(report.failures)}")
    seen = {}
    for what, method, path, detail in report.failures:
        key = (what, method, path.split("?")[0], detail[:80])
        seen[key] = seen.get(key, 0) + 1
    for (what, method, path, head), k in sorted(seen.items(), key=lambda kv: -kv[1]):
        print(f"{k:5d} x {what} {method} {path}: {head}")


if __name__ == "__main__":
    main()
