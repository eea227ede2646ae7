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
