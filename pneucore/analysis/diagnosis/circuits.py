"""What a designer can act on when a valve path passes far less than its catalogue value.

A recalibration of the valve's exhaust (or supply) edges far below the catalogue is rarely a
catalogue error: something in the circuit restricts that path. With no volume between a
throttle and the valve edge it is in series with (ISO 6358-3), a meter-out flow control on
both ports, an exhaust silencer and a smaller valve are nearly the same model: the records
of one rig cannot tell them apart, and the diagnosis says so, names the components that
could do it, and the test that would separate them, instead of naming a leak or a line.
"""
from __future__ import annotations

import math

from pneucore.analysis import hypotheses as H
from pneucore.description.paths import VALVE_GROUPS

#: Factor of a path's conductance below which it "passes far less than the catalogue": two
#: typical catalogue errors of a valve's conductance (15 %, hypotheses.BASE_HYPOTHESES) on the
#: logarithm, x0.76; a valve within that is as likely mis-catalogued as restricted
FAR_BELOW = 2.0

#: The components that could restrict each path, and the test that separates them
PATHS = {
    VALVE_GROUPS["exhaust"]: {
        "path": "exhaust path",
        "components": "a meter-out flow control on the ports, an exhaust silencer (or a "
                      "clogged one), or a valve smaller than the catalogue's",
        "test": "repeat a free stroke with the flow controls' needles fully open (or the "
                "silencer off the exhaust port): a meter-out control or a silencer then passes "
                "the catalogue value and the stroke speeds up; a smaller valve does not change. "
                "Throttling one port's needle only tells a flow control (one direction slows) "
                "from a silencer (both do)",
    },
    VALVE_GROUPS["supply"]: {
        "path": "supply path",
        "components": "a meter-in flow control on the ports, a restriction upstream of the "
                      "valve (a regulator, a long or thin supply line, a filter), or a valve "
                      "smaller than the catalogue's",
        "test": "log the pressure at the valve's supply port during a stroke: a restriction "
                "upstream of the valve shows there as a sag, a meter-in control or a smaller "
                "valve does not; opening the flow controls' needles fully then tells the two",
    },
}


def restricted_paths(recalibrate):
    """The valve paths a recalibration finds passing far less than the catalogue: one entry
    per path ``{"path", "factor", "components", "test", "description"}`` (``factor``: the
    conductance found over the catalogue's [-])."""
    out = []
    for r in recalibrate:
        parts = r["path"].split(".")
        if len(parts) != 4 or parts[0] != "valve" or parts[3] != "C" or parts[2] not in PATHS:
            continue
        f = float(r["after"]) / float(r["before"]) if r["before"] else float("nan")
        h = H.BASE_HYPOTHESES.get(r["path"])
        typical = h.typical if h is not None else 0.15
        if not (f > 0.0 and -math.log(f) > FAR_BELOW * math.log1p(typical)):
            continue
        what = PATHS[parts[2]]
        words = (f"the {what['path']} passes {f:.2g} of the catalogue value: "
                 f"{what['components']}; these records cannot tell which (with no volume "
                 "between them and the valve edge they are nearly the same model); this test "
                 f"would: {what['test']}")
        out.append({"path": r["path"], "factor": f, "components": what["components"],
                    "test": what["test"], "description": words})
    return out
