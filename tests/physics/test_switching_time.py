"""On/off valves as catalogues sell them, with their switching times (issue 41 item 3): a stroke
timed from the command (SMC's start-up and full-stroke times) grows by the valve's ON or OFF
time; a pulse shorter than the times' difference never shifts the spool; bad fields name
themselves."""
import pytest

from pneucore import FieldError, model_preset, simulate
from pneucore.physics.valve import switched_command
from pneucore.description.model import Model
from pneucore.description.valve_data import CATALOGUE_VALVES, catalogue_valve

ON, OFF = 0.015, 0.025      # [s], catalogue-like (SMC SY5000: 12-20 ms)
T_CMD = 0.05                # command time [s]
#: Each function's stroke: (start command, switched-to command, x0 as a fraction of the
#: stroke, the time that applies, initial {p_a, p_b} in units of the supply, or None = ambient)
CASES = {
    "3/2": (0.0, 1.0, 0.0, "on_time", None),
    "5/2": (-1.0, 1.0, 0.0, "on_time", (0.0, 1.0)),
    "5/2-return": (1.0, -1.0, 1.0, "off_time", (1.0, 0.0)),
    "5/3-closed": (0.0, 1.0, 0.0, "on_time", None),
    "5/3-exhausted": (0.0, -1.0, 1.0, "on_time", None),
    "5/3-pressurised": (0.0, 1.0, 0.0, "on_time", (1.0, 1.0)),
}


def _model(function, on, off):
    m = model_preset("paper-4way")
    m["valve"] = catalogue_valve({"function": function.removesuffix("-return"),
                                  "supply": {"qn": 400.0, "b": 0.3}, "exhaust": {"cv": 0.4, "b": 0.25},
                                  "on_time": on, "off_time": off})
    return m


def _stroke(function, on, off):
    u0, u1, x0, _, ini = CASES[function]
    m = _model(function, on, off)
    p_s, p_0 = m["supply"]["pressure"], m["ambient"]["pressure"]
    initial = {} if ini is None else {"p_a": p_0 + ini[0] * (p_s - p_0),
                                      "p_b": p_0 + ini[1] * (p_s - p_0)}
    if m["valve"]["kind"] == "3/2":
        initial.pop("p_b", None)
    s = {"duration": 0.6, "sample_period": 0.001, "command": [[0.0, u0], [T_CMD, u1]],
         "x0": x0 * m["jack"]["stroke"], "initial": initial}
    return simulate(m, s).stroke_metrics()["strokes"][0]


@pytest.mark.parametrize("function", list(CASES))
def test_a_stroke_from_the_command_grows_by_the_switching_time(function):
    delay = {"on_time": ON, "off_time": OFF}[CASES[function][3]]
    base = _stroke(function, 0.0, 0.0)
    late = _stroke(function, ON, OFF)
    assert base["t_command"] == late["t_command"] == T_CMD    # timed from the signal
    assert base["start_up_time"] is not None and base["full_stroke_time"] is not None, base
    # the valve shifts `delay` later; the rest of the stroke is the same motion (1e-5 s: the
    # event location's tolerance, far below a millisecond's switching time)
    assert late["start_up_time"] - base["start_up_time"] == pytest.approx(delay, abs=1e-5)
    assert late["full_stroke_time"] - base["full_stroke_time"] == pytest.approx(delay, abs=1e-4)


def test_switched_command_drops_a_pulse_shorter_than_the_times_difference():
    spool, sig = switched_command([[0, 0], [0.1, 1], [0.105, 0]], 0.020, 0.010, rest=0)
    assert spool.tolist() == [[0.0, 0.0]] and sig.tolist() == [0.0]
    # bistable: every change takes on_time
    spool, _ = switched_command([[0, -1], [0.1, 1], [0.3, -1]], 0.02, 0.05, rest=None)
    assert spool[:, 0].tolist() == pytest.approx([0.0, 0.12, 0.32])


def test_catalogue_functions_and_figures():
    assert set(CATALOGUE_VALVES) == {"3/2", "5/2", "5/3-closed", "5/3-exhausted", "5/3-pressurised"}
    v = catalogue_valve({"function": "5/2", "supply": {"C": 2e-8, "b": 0.3}, "bistable": True})
    assert v["rest_opening"] is None and Model.from_dict(dict(model_preset("paper-4way"), valve=v))
    # the same valve by its nominal flow: ISO 6358 at 6 bar / 1 bar drop, 2 dm^3/(s bar) and
    # b 0.3 give 508.5 NL/min
    v2 = catalogue_valve({"function": "5/2", "supply": {"qn": 508.54, "b": 0.3}})
    assert v2["ports"]["P-A"]["C"][1] == pytest.approx(2e-8, rel=1e-3)


@pytest.mark.parametrize("d, field", [
    ({"function": "5/4", "supply": {"C": 1e-8, "b": 0.3}}, "valve.function"),
    ({"function": "5/2", "supply": {"C": 1e-8, "b": 0.3}, "on_time": -0.01}, "valve.on_time"),
    ({"function": "5/3-closed", "supply": {"C": 1e-8, "b": 0.3}, "bistable": True}, "valve.bistable"),
    ({"function": "5/2", "supply": {"C": 1e-8}}, "valve.supply.b"),
])
def test_bad_catalogue_fields_name_themselves(d, field):
    with pytest.raises(FieldError) as e:
        catalogue_valve(d)
    assert e.value.path == field


def test_a_linear_command_with_switching_times_is_refused():
    m = _model("5/2", ON, OFF)
    with pytest.raises(FieldError) as e:
        simulate(m, {"duration": 0.1, "command": [[0, -1], [0.05, 1]], "command_interpolation": "linear"})
    assert e.value.path == "scenario.command_interpolation"
    with pytest.raises(FieldError) as e:
        Model.from_dict(dict(m, valve=dict(m["valve"], off_time=2.0)))
    assert e.value.path == "valve.off_time"


def test_switching_times_survive_the_effects_and_the_copy():
    # an effect rebuilds the model (Model.copy): the times must come along (they were lost)
    base = _model("5/2", 0.0, 0.0)
    late = _model("5/2", ON, OFF)
    for m in (base, late):
        m["effects"] = {"meter_out_throttle": {"C_a": 5e-9, "b_a": 0.3, "C_b": 5e-9, "b_b": 0.3}}
    assert Model.from_dict(late).copy().valve.on_time == ON
    # at rest, chamber B at the supply (as a retraction leaves it): nothing moves before the shift
    s = {"duration": 0.6, "command": [[0.0, -1.0], [T_CMD, 1.0]], "x0": 0.0,
         "initial": {"p_b": late["supply"]["pressure"]}}
    a, b = (simulate(m, s).stroke_metrics()["strokes"][0] for m in (base, late))
    assert b["start_up_time"] - a["start_up_time"] == pytest.approx(ON, abs=1e-5)


def test_a_synthetic_record_logs_the_command_sent_not_the_spools():
    """A rig logs the command it sends; the core's ``u`` is the spool's, shifted by the valve's
    switching times. The synthetic record of a valve with its ON/OFF times carried the spool's
    ``u``, and the same model replayed on it delayed the command a second time (its error far
    above the noise). Logged as sent, the truth replays to its own noise floor."""
    from pneucore.analysis.compare import compare
    from pneucore.data.synthetic import synthesize
    m = _model("5/2", ON, OFF)
    sc = {"duration": 0.6, "sample_period": 1e-3, "x0": 0.0,
          "command": [[0.0, -1.0], [0.1, 1.0], [0.35, -1.0]]}
    meas = synthesize(m, sc, seed=2)
    # the logged command switches at 0.1 s, the spool 15 ms later
    t, u = meas.t, meas.signals["u"]
    assert u[(t > 0.1005) & (t < 0.11)].min() == 1.0
    err = compare(m, [{"scenario": sc, "measurement": meas}]).overall
    # the noise floor of a 12-bit record with the default noise: about 0.1 % (a second delay
    # of 15 ms put the error at several per cent)
    assert err < 0.003, err
