"""The page with a rig's file, in Chromium (issue 11): upload a decimal-comma export with a
units row and a column to map, fit the moving mass on it, export the comparison as CSV,
upload the export again, and open the HTML report offline.

The rig data are the paper-4way model's own Fig. 10 pulse run with a heavier moving mass
(2.5 kg against the preset's 2.0), written as a German lab would: semicolons, decimal
commas, ``Zeit;Ventil;Kanal 3;p_B;Weg`` over ``ms;%;bar(g);bar(g);mm``.
"""
from __future__ import annotations


import numpy as np
import pytest

from pneucore import model_preset, scenario_preset
from pneucore.simulate import simulate
from test_page import (TIMEOUT_MS, browser, page_errors, server, wait_status,  # noqa: F401
                       wide_context)

TRUE_MASS = 2.5


@pytest.fixture(scope="module")
def context(browser):  # noqa: F811
    yield from wide_context(browser)


@pytest.fixture(scope="module")
def rig_file(tmp_path_factory):
    m = model_preset("paper-4way")
    m["jack"]["moving_mass"] = TRUE_MASS
    res = simulate(m, scenario_preset("paper-fig10-pulses"))
    amb = m["ambient"]["pressure"]
    lines = ["Zeit;Ventil;Kanal 3;p_B;Weg;Kommentar", "ms;%;bar(g);bar(g);mm;-"]
    for t, u, pa, pb, x in zip(res.t, res.u, res.p_a, res.p_b, res.x):
        cells = [f"{1e3 * t:.6g}", f"{100 * u:.6g}", f"{(pa - amb) / 1e5:.9g}", f"{(pb - amb) / 1e5:.9g}",
                 f"{1e3 * x:.9g}"]
        lines.append(";".join(c.replace(".", ",") for c in cells) + ";ok")
    path = tmp_path_factory.mktemp("rig") / "pruefstand.csv"
    path.write_bytes("\r\n".join(lines).encode("cp1252"))
    return path, res


def _wait_status(page, pattern):
    return wait_status(page, pattern)


def test_upload_with_mapping(page, rig_file):
    path, _ = rig_file
    page.click("#upload-box summary")
    page.set_input_files("#upload-file", str(path))
    page.wait_for_selector("#upload-mapping select[data-column='Kanal 3']")
    text = page.inner_text("#upload-mapping")
    assert "decimal mark “,”" in text and "units row found" in text
    # aliases proposed; "Kanal 3" (channel 3) is no alias: the user maps it, "Kommentar" stays ignored
    assert page.input_value("#upload-mapping select[data-column='Zeit']") == "t"
    assert page.input_value("#upload-mapping select[data-column='Kanal 3']") == ""
    page.select_option("#upload-mapping select[data-column='Kanal 3']", "p_a")
    page.fill("#upload-name", "pruefstand")
    page.click("#btn-upload")
    _wait_status(page, "Dataset pruefstand stored")
    report = page.inner_text("#upload-report")
    assert "Kanal 3 → p_a: barg → Pa" in report and "Ignored columns: Kommentar" in report


def test_fit_moving_mass_and_apply(page):
    page.wait_for_selector("#cal-params input[data-path='jack.moving_mass'][data-key='value']")
    assert page.is_checked("#cal-params input[type=checkbox][data-path='jack.moving_mass']")
    page.click("#btn-cal-fit")
    _wait_status(page, "Fit done")
    row = page.locator("#cal-values tr[data-path='jack.moving_mass'] td").all_inner_texts()
    # noise-free data from the same model: only the 6-9 digits written in the file and the
    # solver's rtol 1e-5 separate the fit from the truth; 1 % is a wide margin
    assert float(row[1]) == pytest.approx(TRUE_MASS, rel=0.01)
    assert "AIC" in page.inner_text("#cal-report") and "BIC" in page.inner_text("#cal-report")
    page.click("#btn-cal-apply")
    _wait_status(page, "Comparison done")
    assert float(page.input_value("#jack-moving_mass")) == pytest.approx(TRUE_MASS, rel=0.01)
    with page.expect_download() as dl:
        page.click("#btn-cal-download")
    import json
    fitted = json.loads(open(dl.value.path()).read())
    assert fitted["jack"]["moving_mass"] == pytest.approx(TRUE_MASS, rel=0.01)


def test_every_calibration_error_at_once(page):
    page.fill("#cal-params input[data-path='jack.moving_mass'][data-key='min']", "")
    page.fill("#cal-params input[data-path='jack.moving_mass'][data-key='max']", "")
    page.click("#btn-cal-fit")
    _wait_status(page, "Fit refused: 2 errors")
    assert page.locator("#status-errors li").count() == 2
    page.click("#btn-cal-refresh")
    page.wait_for_function("() => document.querySelector(\"#cal-params input[data-path='jack.moving_mass'][data-key='min']\").value !== ''")


def _upload_back(page, path, column, name, samples):
    """Upload a downloaded file back through the page's mapping step (``column`` one of its
    columns), store it as ``name``, and check the stored dataset has ``samples`` samples."""
    page.set_input_files("#upload-file", str(path))
    page.wait_for_selector(f"#upload-mapping select[data-column='{column}']")
    page.fill("#upload-name", name)
    page.click("#btn-upload")
    msg = _wait_status(page, f"Dataset {name} stored")
    assert f"({samples} samples" in msg


def test_export_comparison_and_upload_it_back(page, rig_file, tmp_path):
    _, res = rig_file
    with page.expect_download() as dl:
        page.click("#btn-compare-csv")
    saved = tmp_path / "comparison.csv"
    dl.value.save_as(saved)
    assert saved.read_text().splitlines()[1].startswith("experiment,t[s],u[-],p_a[Pa],p_a_model[Pa]")
    _upload_back(page, saved, "t[s]", "re-uploaded", len(res.t))


def test_simulation_npz_download_reads_back_with_numpy(page, tmp_path):
    import io
    import json

    import numpy as np
    with page.expect_download() as dl:
        page.click("#btn-sim-npz")
    saved = tmp_path / "simulation.npz"
    dl.value.save_as(saved)
    assert dl.value.suggested_filename == "simulation.npz"
    z = np.load(io.BytesIO(saved.read_bytes()))   # no pickle
    meta = json.loads(z["meta.json"])
    assert meta["units"]["p_a"] == "Pa" and meta["status"] == 0
    assert len(z["t"]) == len(z["p_a"]) > 10 and np.all(np.diff(z["t"]) > 0)
    assert np.all(z["p_a"] > 0)   # absolute pressures
    _wait_status(page, "saved simulation.npz")
    # ... and the same file uploads back as a measurement, through the page's mapping step
    page.evaluate("document.getElementById('upload-file').closest('details').open = true")
    _upload_back(page, saved, "p_a", "npz back", len(z["t"]))


def test_html_report_opens_offline(page, browser, tmp_path):  # noqa: F811
    with page.expect_download() as dl:
        page.click("#btn-compare-report")
    saved = tmp_path / "report.html"
    dl.value.save_as(saved)
    ctx = browser.new_context(offline=True)
    try:
        requests = []
        p = ctx.new_page()
        p.on("request", lambda r: requests.append(r.url))
        p.goto(saved.as_uri())
        assert p.locator("svg polyline").count() >= 6
        assert "Data provenance" in p.inner_text("body")
        assert [u for u in requests if not u.startswith("file:")] == []
    finally:
        ctx.close()


def test_unit_switch_from_the_service(page):
    """SI, engineering (bar abs) and gauge: one switch converts every input and label; what is
    sent stays SI absolute. The systems come from GET /api/units."""
    page.select_option("#unit-system", "si")
    assert page.inner_text("label[for=jack-bore]").endswith("[m]")
    assert page.input_value("#valve-c-unit") == "si"
    assert float(page.input_value("#jack-bore")) == pytest.approx(0.032)
    assert float(page.input_value("#scn-x0")) == pytest.approx(page.evaluate("S.scenario.x0"))
    page.select_option("#unit-system", "engineering-gauge")
    amb = page.evaluate("S.model.ambient.pressure")
    sup = page.evaluate("S.model.supply.pressure")
    assert page.inner_text("label[for=supply-pressure]").endswith("[bar g]")
    assert float(page.input_value("#supply-pressure")) == pytest.approx((sup - amb) / 1e5)
    assert page.inner_text("label[for=ambient-pressure]").endswith("[bar abs]")   # never gauge
    page.fill("#supply-pressure", "6")
    assert page.evaluate("S.model.supply.pressure") == pytest.approx(6e5 + amb)
    page.select_option("#unit-system", "engineering")
    assert float(page.input_value("#supply-pressure")) == pytest.approx((6e5 + amb) / 1e5)
    assert page.inner_text("label[for=scn-x0]").endswith("[mm]")


def test_plots_follow_the_unit_switch(page):
    """The plots are drawn in the header's unit system too: titles and values."""
    def y_title(div):
        return page.evaluate("(id) => document.getElementById(id).layout.yaxis.title.text", div)

    def first_p_a():
        return page.evaluate("document.getElementById('plot-pressure').data[0].y[0]")
    page.evaluate("S.sim = null")
    page.click("#btn-simulate")
    page.wait_for_function("() => !!S.sim && (document.getElementById('plot-pressure').data || []).length > 0")
    p0 = page.evaluate("S.sim.series.p_a[0]")
    amb = page.evaluate("S.model.ambient.pressure")
    page.select_option("#unit-system", "si")
    assert (y_title("plot-pressure"), y_title("plot-position")) == ("pressure [Pa]", "position x [m]")
    assert first_p_a() == pytest.approx(p0)
    page.select_option("#unit-system", "engineering-gauge")
    assert y_title("plot-pressure") == "pressure [bar g]"
    assert first_p_a() == pytest.approx((p0 - amb) / 1e5)
    page.select_option("#unit-system", "engineering")
    assert (y_title("plot-pressure"), y_title("plot-position")) == ("pressure [bar abs]", "position x [mm]")
    assert first_p_a() == pytest.approx(p0 / 1e5)

    # temperatures follow the same switch (issue 24: no K in one panel and °C in another):
    # kelvin in SI, degrees Celsius in engineering units, offset 273.15 K exactly
    def first_t_a():
        return page.evaluate("document.getElementById('plot-temperature').data[0].y[0]")
    t0 = page.evaluate("S.sim.series.T_a[0]")
    assert y_title("plot-temperature") == "temperature [°C]"
    assert first_t_a() == pytest.approx(t0 - 273.15)
    page.select_option("#unit-system", "si")
    assert y_title("plot-temperature") == "temperature [K]"
    assert first_t_a() == pytest.approx(t0)
    page.select_option("#unit-system", "engineering")


def test_stored_data_listed_and_deletable(page):
    page.click("#stored-box summary")
    page.wait_for_selector("#stored-lists ul[data-kind=datasets] li[data-id]")
    row = page.locator("#stored-lists ul[data-kind=datasets] li", has_text="re-uploaded")
    assert row.count() == 1
    did = row.get_attribute("data-id")
    loads = int(page.get_attribute("#stored-lists", "data-loads"))
    page.once("dialog", lambda d: d.accept())
    row.locator("button").click()
    _wait_status(page, f"Deleted dataset {did}")
    page.wait_for_function("(n) => Number(document.getElementById('stored-lists').dataset.loads) > n", arg=loads)
    assert page.locator(f"#stored-lists li[data-id='{did}']").count() == 0
    assert did not in page.evaluate("S.datasets.map(d => d.id)")
    assert page.locator("#stored-lists ul[data-kind=sessions]").count() == 1
    assert page.locator("#stored-lists ul[data-kind=studies]").count() == 1


@pytest.mark.parametrize("path,selector", [("/docs", ".swagger-ui .info .title"), ("/redoc", "h1")])
def test_docs_render_without_the_internet(browser, server, path, selector):  # noqa: F811
    """Swagger UI and ReDoc render with every request outside the service refused. ReDoc asks
    the internet for one thing only: its "API docs by Redocly" logo image, which may fail."""
    ctx = browser.new_context()
    try:
        outside = []

        def guard(route):
            if route.request.url.startswith(server):
                route.continue_()
            else:
                outside.append((route.request.resource_type, route.request.url))
                route.abort()
        ctx.route("**/*", guard)
        p = ctx.new_page()
        p.goto(server + path)
        p.wait_for_selector(selector, timeout=TIMEOUT_MS)
        assert "pneucore" in p.inner_text(selector)
        assert [u for kind, u in outside if kind != "image"] == []
    finally:
        ctx.close()


def test_rig_signals_in_the_mapping_table(page, tmp_path):
    """Issue 29: the mapping table offers the load cell, the flow meters and the supply gauge
    with their SI units, and the upload reads them in the rig's units."""
    lines = ["Zeit;Ventil;Kraft;Durchfluss;Versorgung", "ms;%;kN;L/min ANR;bar(g)"]
    lines += [f"{10 * i};0;0,2;100;6" for i in range(20)]
    path = tmp_path / "lastzelle.csv"
    path.write_bytes("\r\n".join(lines).encode("cp1252"))
    page.evaluate("document.getElementById('upload-file').closest('details').open = true")
    page.set_input_files("#upload-file", str(path))
    sel = "#upload-mapping select[data-column='Kraft']"
    page.wait_for_selector(sel)
    options = page.eval_on_selector(sel, "s => [...s.options].map(o => o.textContent)")
    for text in ("F [N]", "q_a [kg/s]", "q_b [kg/s]", "q_s [kg/s]", "p_s [Pa]"):
        assert text in options, options
    page.select_option(sel, "F")
    page.select_option("#upload-mapping select[data-column='Durchfluss']", "q_s")
    page.select_option("#upload-mapping select[data-column='Versorgung']", "p_s")
    page.fill("#upload-name", "lastzelle")
    page.click("#btn-upload")
    _wait_status(page, "Dataset lastzelle stored")
    report = page.inner_text("#upload-report")
    assert "Kraft → F: kN → N" in report and "Durchfluss → q_s: L/min ANR → kg/s" in report
    assert "Versorgung → p_s: barg → Pa" in report
