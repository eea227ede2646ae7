"""``pneucore --help`` whole, ``pneucore run`` printing the stroke table (issue 41, item 8)."""
import pytest

from pneucore.cli import main


def test_help_description_is_a_whole_sentence(capsys):
    with pytest.raises(SystemExit):
        main(["--help"])
    out = capsys.readouterr().out
    # the first line of the docstring alone stopped at "... ``pneucore"
    assert "run the modelling loop on measurement files" in out
    assert "``" not in out and ":mod:" not in out


def test_run_prints_the_stroke_table(capsys):
    assert main(["run", "--scenario", "paper-fig9-switching", "--model", "paper-3way"]) == 0
    out = capsys.readouterr().out
    assert "strokes (SMC: times from the valve switching):" in out
    header = [l for l in out.splitlines() if "full s" in l]
    assert header and "start-up s" in header[0] and "end m/s" in header[0]


def test_run_says_the_cyclic_start_state(tmp_path, capsys):
    import json
    scen = {"duration": 1.0, "sample_period": 0.001, "command": [[0, 0], [0.01, 1], [0.5, -1]],
            "x0": 0.0, "start": "cyclic"}
    f = tmp_path / "cycle.json"
    f.write_text(json.dumps(scen))
    assert main(["run", "--scenario", str(f)]) == 0
    out = capsys.readouterr().out
    import re
    # the running machine's extension starts with chamber B at the supply (7 bar abs)
    assert "start: cyclic steady state after" in out
    assert re.search(r"p_b (6\.99\d\d|7\.00\d\d) bar abs", out), out
    rows = [l.split() for l in out.splitlines()]
    rows = [r for r in rows if len(r) > 2 and r[1] in ("extend", "retract", "partial")]
    assert [(r[0], r[1]) for r in rows] == [("0.0100", "extend"), ("0.5000", "retract")]
