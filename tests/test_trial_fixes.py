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


def _row(name, status="ok"):
    from pipeline.stages import PartResult

    return PartResult(name, None, status=status, figures={"area_m2": 1.5})


def test_summary_table_name_column_fits_the_longest_name():
    from pipeline.report import summary_table

    long = "part1_P1_S01_B01-1-1-1"  # 22 characters: ran into the status column
    lines = summary_table([_row("a"), _row(long), _row(long + "-extra", "failed")]).splitlines()
    header, rows = lines[0], lines[2:]
    assert rows[1].split()[:2] == [long, "ok"] and rows[2].split()[:2] == [long + "-extra", "failed"]
    # the columns stay aligned: every row's status starts under the header's
    at = header.index("status")
    assert all(row[at - 1] == " " and row[at:].split()[0] in ("ok", "failed") for row in rows)
    assert len(lines[1]) == len(header)


def test_summary_table_short_names_as_before():
    from pipeline.report import summary_table

    lines = summary_table([_row("bilge_plate")]).splitlines()
    assert lines[0].startswith("part" + " " * 18 + "status  ")
    assert lines[2].startswith("bilge_plate" + " " * 11 + "ok      ")
