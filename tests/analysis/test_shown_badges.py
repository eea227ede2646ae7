"""Badges never contradict the figures beside them (issue 39, item 4): one function
(:func:`pneucore.analysis.shown.card_badges`) for the API, the page and the reports."""
import pytest

from pneucore.analysis.shown import card_badges, change_words

ALPHA, BIC = 0.05 / 4, -10.0     # the diagnosis's level over four candidates; Kass & Raftery


def _cand(**kw):
    c = {"error_before": 0.2659, "error_after_overall": 0.2459, "p_value": 1e-6,
         "delta_bic": -40.0, "significant": True, "strong": True, "material": True,
         "fit_success": True, "held_out": {}}
    c.update(kw)
    return c


def _names(c):
    return [b["name"] for b in card_badges(c, ALPHA, BIC)]


def test_evidence_that_agrees_is_badged():
    assert _names(_cand()) == ["significant", "strong", "material"]


def test_no_evidence_badge_beside_a_rising_error():
    # issue 39: "significant, strong" on a card whose effect raises the error 26.59 -> 29.15 %
    n = _names(_cand(error_after_overall=0.2915))
    assert "significant" not in n and "strong" not in n and "material" not in n
    assert "raises the error" in n


def test_held_out_prediction_is_named_as_such_not_as_the_p_value():
    # issue 39: "significant" on p = 0.094, delta BIC +1.7, a fit that did not converge
    c = _cand(p_value=0.094, delta_bic=1.7, held_out={"predicts": True,
                                                      "predicts_by": ["blocks in time"]})
    n = _names(c)
    assert "significant" not in n and "strong" not in n and "predicts held-out data" in n
    c["fit_success"] = False
    c["fit_message"] = "did not converge: max evaluations"
    n = _names(c)
    assert n == ["material", "fit did not converge"]


@pytest.mark.parametrize("b,a,words", [(0.2593, 0.2747, "raises the overall error from 25.93 % to 27.47 %"),
                                       (0.2747, 0.0913, "lowers the overall error from 27.47 % to 9.13 %"),
                                       (0.1, 0.1, "leaves the overall error at 10.00 %")])
def test_the_words_follow_the_figures(b, a, words):
    assert change_words(b, a) == words


def test_the_explanation_says_what_the_figures_say():
    from pneucore.analysis.diagnosis.evidence import explain
    from pneucore.description.effects import EFFECTS
    cand = {"improvement": [], "params": {}, "error_before": 0.2593,
            "error_after_overall": 0.2747, "p_value": 0.5, "delta_bic": 3.0}
    text = explain(EFFECTS["piston_leakage"], cand, 0.01)
    assert "raises the overall error from 25.93 % to 27.47 %" in text and "lowers" not in text
