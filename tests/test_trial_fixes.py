"""Defects from the new-user trial: the heating label's plural, the console summary's name
column, the hull image's plates."""

from pipeline.shop.heating import group_text


def _group(lines):
    return {"group": 3, "lines": lines, "side": "drawn", "shape": "dome", "max_required_strain": 0.0033,
            "passes": 1}


def test_heating_label_says_line_for_one_line():
    assert group_text(_group(1), 0.43).startswith("HEAT G3 (1 LINE): THIS SIDE (INSIDE OF ROLL), SHRINK 3.3 MM/M")
    assert group_text(_group(2), 0.43).startswith("HEAT G3 (2 LINES): ")
    assert group_text(_group(9), 0.43) == ("HEAT G3 (9 LINES): THIS SIDE (INSIDE OF ROLL), SHRINK 3.3 MM/M, "
                                           "0.43 MM A LINE")
