"""The command line proposes a command like the page (issue 39, item 9): ``pneucore
propose-command FILE`` and ``--propose-command`` on the loop's commands, on a record without a
command column (the synthetic record shaped like the real one)."""
import json

from loop_record import DT, MAPPING, effective_edges, record_csv
from pneucore.cli import main

#: Within two samples of the turns, as the API's proposal (a rounding added)
TOL = 2 * DT + 1e-9


def _files(tmp_path):
    f = tmp_path / "rig.csv"
    f.write_text(record_csv())
    cols = tmp_path / "map.json"
    cols.write_text(json.dumps(MAPPING))
    return f, cols


def test_propose_command_prints_and_writes_the_proposal(tmp_path, capsys):
    f, cols = _files(tmp_path)
    out = tmp_path / "prop.json"
    assert main(["propose-command", str(f), "--columns", str(cols), "--json", str(out)]) == 0
    text = capsys.readouterr().out
    assert f"{len(effective_edges())} pulse(s)" in text and "where that fall starts" in text
    prop = json.loads(out.read_text())
    for (a, b), (ta, tb) in zip(prop["pulses"], effective_edges()):
        assert abs(a - ta) <= TOL and abs(b - tb) <= TOL
    assert prop["command"][0][1] == 0.0 and len(prop["edges"]) == 2 * len(effective_edges())


def test_the_loop_proposes_instead_of_refusing(tmp_path, capsys):
    f, cols = _files(tmp_path)
    model = tmp_path / "m.json"
    from loop_record import truth_dict
    model.write_text(json.dumps(truth_dict()))
    # without the flag: refused, the message naming the command line's way
    assert main(["compare", "--model", str(model), "--data", str(f), "--columns", str(cols)]) == 2
    err = capsys.readouterr().err
    assert "pneucore propose-command" in err and "--propose-command" in err
    assert main(["compare", "--model", str(model), "--data", str(f), "--columns", str(cols),
                 "--propose-command"]) == 0
    text = capsys.readouterr().out
    assert "proposed command" in text and "Eq. 25 error" in text


def test_bad_switching_time_is_refused(tmp_path, capsys):
    f, cols = _files(tmp_path)
    assert main(["propose-command", str(f), "--columns", str(cols), "--switching-time", "-1"]) == 2
    assert "--switching-time" in capsys.readouterr().err
