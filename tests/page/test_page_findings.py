"""The page shows the diagnosis's two kinds of finding apart, and applies them with one click.

Driven in Chromium like tests/page/test_page.py (its fixtures are reused): the
"piston-leak" sample (the paper's jack with a hidden piston leak) is compared
with a model whose heat coefficient is mis-set (15 instead of the true
25 W/(m^2 K)). The diagnosis must show "mis-set: heat coefficient 15 -> ~25"
and "missing: piston_leakage" as separate findings; one click applies both, and
the history chart draws the error falling towards the dashed noise floor.
"""
from test_page import (ARTIFACTS, browser, context, no_script_errors, page_errors,  # noqa: F401
                       plot_data, server)

import pytest


def test_mis_set_and_missing_are_shown_apart_and_applied_in_one_click(page):
    page.fill("#heat-coefficient", "15")
    page.dispatch_event("#heat-coefficient", "change")
    page.select_option("#dataset-select", "sample:piston-leak")
    page.click("#btn-compare")
    page.wait_for_function("() => ((document.getElementById('history-plot').data || [])[0] || {}).y?.length === 1")
    page.click("#btn-diagnose")
    page.wait_for_function("() => document.getElementById('diag-progress').dataset.done === 'true'")
    misset = page.locator("#diag-findings .finding.misset")
    texts = [misset.nth(i).inner_text() for i in range(misset.count())]
    heat = [t for t in texts if "heat coefficient" in t]
    assert heat, texts
    # "mis-set: heat coefficient 15 → 25 W/(m^2 K)": the true value within 5 % (the locked hold
    # test pins h to a fraction of a percent once the leak is modelled)
    after = float(heat[0].split("→")[1].split()[0])
    assert abs(after - 25.0) <= 0.05 * 25.0, heat[0]
    assert "W/(m^2 K)" in heat[0]
    missing = page.inner_text("#diag-findings .finding.missing")
    assert "missing:" in missing and "piston_leakage" in missing
    assert page.locator("#btn-apply-recalibration").count() == 1
    # "error before" explains itself (issue 24): the model as given, the refitted base values
    # with the heat coefficient among them, and what adding a finding takes with it
    explained = page.inner_text("#diag-error-explained")
    assert "Your model as given" in explained and "heat coefficient" in explained, explained
    assert "error before" in explained and "changes" in explained, explained

    page.click("#btn-apply-findings")
    page.wait_for_function("() => ((document.getElementById('history-plot').data || [])[0] || {}).y?.length === 2")
    traces = plot_data(page, "history-plot")
    y = traces[0]["y"]
    assert y[1] < 0.5 * y[0], y
    floor = [t for t in traces if t["name"] == "noise floor"]
    assert floor and floor[0]["y"][0] > 0
    # the new model is at the floor: within 20 % of it (a refit of 2 parameters on ~5000 samples)
    assert y[1] <= 1.2 * floor[0]["y"][0], (y, floor[0]["y"])
    assert float(page.input_value("#heat-coefficient")) == pytest.approx(after, rel=0.01)
    assert page.locator("#effect-piston_leakage").count() == 1
    page.wait_for_selector("#diag-verdict .stale-note")
    assert page.locator("#diag-findings button:enabled").count() == 0
    ARTIFACTS.mkdir(exist_ok=True)
    page.locator("#panel-diagnose").screenshot(path=str(ARTIFACTS / "findings.png"))


def test_initial_state_confounded_groups_and_separating_experiments_are_shown(page):
    # a diagnosis as POST /api/diagnose answers it on a rig left pressurised, with a load
    # confounded with the Coulomb levels and two effects the records cannot tell apart;
    # server text carries markup, which must show as text (esc())
    result = {
        "verdict": None, "message": "<b>m</b>", "ranking": [], "score_pass": [],
        "error_before": {"overall": 0.02}, "noise_floor": {"p_a": 0.001},
        "initial_state": [{"experiment": "hold<img src=x onerror=alert(1)>", "path": "initial.p_a",
                           "label": "pressure A", "before": 101325.0, "after": 310000.0,
                           "stderr": 120.0, "unit": "Pa"}],
        "recalibrate": [
            {"path": "jack.load_force", "label": "load force", "before": 0.0, "after": 40.2,
             "stderr": 3.0, "unit": "N",
             "confounded_with": ["friction.extend.fc0", "friction.retract.fc0"]},
            {"path": "friction.extend.fc0", "label": "Coulomb force, extension", "before": 20.0,
             "after": 12.0, "stderr": 2.0, "unit": "N", "confounded_with": ["jack.load_force"]}],
        "alternatives": [{"effect": "dead_volume", "note": "cannot tell dead_volume from the "
                          "heat coefficient on these records; a test with chamber B at half "
                          "pressure would separate them"}],
        "remaining": {"error": 0.0011, "noise_floor": 0.001, "at_floor": True},
    }
    page.evaluate("(r) => { S.diag = { result: r }; renderDiagnosis(); }", result)
    initial = page.inner_text("#diag-findings .finding.initial")
    assert "initial state, not recorded" in initial and "pressure A" in initial
    assert "hold<img src=x onerror=alert(1)>" in initial   # shown as text, never as markup
    assert page.locator("#diag-findings img").count() == 0
    misset = page.locator("#diag-findings .finding.misset")
    load = misset.nth(0).inner_text()
    assert "load force" in load and "only in combination with" in load
    assert "Coulomb force, extension" in load and "friction.retract.fc0" in load
    assert "only in combination with load force" in misset.nth(1).inner_text()
    alt = page.inner_text("#diag-findings .finding.alternative")
    assert "chamber B at half pressure" in alt
