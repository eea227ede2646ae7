"""Exports (issue 11 item 4): CSV answers of simulate and compare read back unchanged by an
upload; the CLI's --csv writes the same format."""
import json
import subprocess
import sys

import numpy as np
import pytest

from api_conftest import client, db_path  # noqa: F401
from pneucore import model_preset, scenario_preset

CSV = {"accept": "text/csv"}


def test_simulation_csv_round_trip(client):
    body = {"model": model_preset("paper-4way"), "scenario": scenario_preset("paper-fig10-pulses")}
    r = client.post("/api/simulate", json=body, headers=CSV)
    assert r.status_code == 200 and r.headers["content-type"].startswith("text/csv")
    text = r.text
    header = text.splitlines()[1].split(",")
    assert header[:4] == ["t[s]", "u[-]", "p_a[Pa]", "p_b[Pa]"] and "x[m]" in header
    up = client.post("/api/datasets", content=text.encode(), headers={"content-type": "text/csv"})
    assert up.status_code == 201, up.text
    rep = up.json()["import"]
    assert "m_a[kg]" in rep["ignored_columns"] and rep["warnings"] == []
    stored = client.get(f"/api/datasets/{up.json()['id']}").json()["measurement"]
    sim = client.post("/api/simulate", json=body).json()["series"]
    for s in ("t", "u", "p_a", "p_b", "x", "v", "T_a", "T_b"):
        # 10 significant digits written: relative rounding <= 5e-10 (1e-9 for t = 0-based sums)
        np.testing.assert_allclose(stored[s], sim[s], rtol=1e-9, atol=1e-12, err_msg=s)


def test_comparison_csv_round_trip_and_residuals(client):
    exp = [{"dataset_id": "sample-clean-free-pulses"}]
    body = {"model": model_preset("paper-4way"), "experiments": exp}
    r = client.post("/api/compare", json=body, headers=CSV)
    assert r.status_code == 200, r.text
    lines = r.text.splitlines()
    header = lines[1].split(",")
    assert header[:3] == ["experiment", "t[s]", "u[-]"] and "p_a_residual[Pa]" in header
    rows = np.array([[float(c) if c else np.nan for c in ln.split(",")[1:]] for ln in lines[2:]])
    j = header.index("p_a[Pa]") - 1
    # residual = model - measured, each written to 10 digits of ~5e5 Pa: agree to ~1e-4 Pa
    np.testing.assert_allclose(rows[:, j + 2], rows[:, j + 1] - rows[:, j], atol=1e-3)
    up = client.post("/api/datasets", content=r.text.encode(), headers={"content-type": "text/csv"})
    assert up.status_code == 201, up.text
    stored = client.get(f"/api/datasets/{up.json()['id']}").json()["measurement"]
    orig = client.get("/api/datasets/sample-clean-free-pulses").json()["measurement"]
    for s in ("t", "u", "p_a", "p_b", "x"):
        np.testing.assert_allclose(stored[s], orig[s], rtol=1e-9, err_msg=s)  # 10 digits


def test_cli_csv_is_the_same_format(tmp_path):
    out = tmp_path / "run.csv"
    p = subprocess.run([sys.executable, "-m", "pneucore", "run", "--model", "paper-3way",
                        "--scenario", "paper-fig9-switching", "--csv", str(out)],
                       capture_output=True, text=True, timeout=600)
    assert p.returncode == 0, p.stderr
    from pneucore.data.measurement import read_csv
    m = read_csv(out)
    assert m.meta["import"]["pneucore_export"] and "p_a" in m.measured_signals
    assert out.read_text().splitlines()[1].startswith("t[s],u[-],p_a[Pa]")


def test_cli_npz_holds_the_run(tmp_path):
    # in process (the CSV test above covers the subprocess entry point)
    import io

    from pneucore.cli import main
    from pneucore import Model, Scenario, scenario_preset, simulate
    out = tmp_path / "run.npz"
    assert main(["run", "--model", "paper-3way", "--scenario", "paper-fig9-switching",
                 "--npz", str(out)]) == 0
    z = np.load(io.BytesIO(out.read_bytes()))
    res = simulate(Model.from_dict(model_preset("paper-3way")),
                   Scenario.from_dict(scenario_preset("paper-fig9-switching")))
    assert np.array_equal(z["p_a"], res.series["p_a"]) and np.array_equal(z["t"], res.t)
    assert json.loads(z["meta.json"])["units"]["p_a"] == "Pa"


def test_cli_unknown_model_lists_presets(capsys):
    from pneucore.cli import main
    assert main(["run", "--model", "nosuch"]) == 2
    err = capsys.readouterr().err
    assert "nosuch" in err and "paper-4way" in err and "Errno" not in err


def test_comparison_report_is_self_contained(client):
    body = {"model": model_preset("paper-4way"), "experiments": [{"dataset_id": "sample-clean-free-pulses"}]}
    r = client.post("/api/reports/compare", json=body)
    assert r.status_code == 200 and r.headers["content-type"].startswith("text/html")
    page = r.text
    assert page.count("<svg") >= 6                   # measured/model and residual per signal
    assert "sample-clean-free-pulses" in page and "Data provenance" in page
    # offline: no script, no external asset of any kind
    assert "<script" not in page and "http://" not in page.replace('xmlns="http://www.w3.org/2000/svg"', "")
    assert "https://" not in page


def test_report_escapes_request_text(client):
    exp = {"name": "<img src=x onerror=alert(1)>", "dataset_id": "sample-clean-locked-hold"}
    body = {"model": {**model_preset("paper-4way"), "name": "<script>alert(2)</script>"}, "experiments": [exp]}
    page = client.post("/api/reports/compare", json=body).text
    assert "<img src=x" not in page and "<script>alert" not in page
    assert "&lt;img src=x onerror=alert(1)&gt;" in page


def test_diagnosis_report_names_the_verdict(client):
    exps = [{"dataset_id": "sample-leak-and-lag-locked-hold"}, {"dataset_id": "sample-leak-and-lag-free-pulses"}]
    r = client.post("/api/reports/diagnose", json={"model": model_preset("paper-4way"), "experiments": exps})
    assert r.status_code == 200, r.text[:500]
    page = r.text
    d = client.post("/api/diagnose", json={"model": model_preset("paper-4way"), "experiments": exps}).json()
    assert f"Verdict: {d['verdict']}" in page and "null" not in page.split("<h2>Model</h2>")[0]
    assert f"With {d['verdict']} added" in page


def test_refinement_report_covers_every_round(client):
    """POST /api/reports/refine (issue 24): every version with its errors, every round's verdict,
    the refined model drawn against the data; offline (no script), user text escaped."""
    exps = [{"dataset_id": "sample-leak-and-lag-locked-hold"},
            {"dataset_id": "sample-leak-and-lag-free-pulses"}]
    body = {"model": model_preset("paper-4way"), "experiments": exps}
    r = client.post("/api/reports/refine", json=body)
    assert r.status_code == 200, r.text[:500]
    assert r.headers["content-type"].startswith("text/html")
    page = r.text
    answer = client.post("/api/refine", json=body).json()
    assert "<script" not in page
    for v in answer["versions"]:
        assert v["label"] in page
    for k in range(1, len(answer["diagnoses"]) + 1):
        assert f"<h2>Round {k}</h2>" in page
    assert "refined model" in page and "{'value'" not in page
