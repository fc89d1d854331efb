"""A signed range bias says long or short by its sign (issue 32: "-0.131 m long")."""

from __future__ import annotations

from coopproc.stages.fusion.calibration_bias import bias_words


def test_a_negative_bias_reads_short_and_a_positive_one_long() -> None:
    assert bias_words(-0.131) == "0.131 m short"
    assert bias_words(0.294) == "0.294 m long"
    assert bias_words(-0.0004) == "0.000 m short"
