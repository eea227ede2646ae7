"""``pneucore identify valve|friction`` on the command line."""
import json

import pytest

from pneucore.cli import main
from pneucore.physics.flow import FLOW_LAWS


def test_valve_from_a_csv(tmp_path, capsys):
    law = FLOW_LAWS["iso6358"]
    rows = ["opening,p_up,p_down,T_up,flow"]
    for u, C in ((0.5, 0.6e-8), (1.0, 1.2e-8)):
        for r in (0.3, 0.6, 0.8, 0.9):
            rows.append(f"{u},{6e5},{r * 6e5},293.15,{law(6e5, 293.15, r * 6e5, 293.15, C, 0.35)!r}")
    src = tmp_path / "points.csv"
    src.write_text("\n".join(rows) + "\n")
    out = tmp_path / "out.json"
    assert main(["identify", "valve", str(src), "--edge", "P-B", "--model", "paper-4way",
                 "--json", str(out)]) == 0
    res = json.loads(out.read_text())
    # exact points: the conductances back to the fit's tolerance
    assert res["edge"]["C"] == [pytest.approx(0.6e-8, rel=1e-6),
                                pytest.approx(1.2e-8, rel=1e-6)]
    assert res["model"]["valve"]["ports"]["P-B"]["opening"] == [0.5, 1.0]
    assert "edge P-B" in capsys.readouterr().out


def test_bad_points_are_an_error_message_not_a_traceback(tmp_path, capsys):
    src = tmp_path / "points.csv"
    src.write_text("opening,p_up,p_down,T_up,flow\n0.5,5e5,6e5,293,0.01\n")
    assert main(["identify", "valve", str(src)]) == 2
    assert "points[0].p_down" in capsys.readouterr().err
