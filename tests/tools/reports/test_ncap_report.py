"""The scorecard page from a hand-made scorecard: AEB on / off side by side in the band's colour,
an FCW cell spanning the pair with its warning TTC, failures and the plain table."""

from __future__ import annotations

from lookahead.tools.reports.ncap import COLOURS, family_grid, render_ncap


def cell(case: str, speed: float, aeb: bool, **kw) -> dict:
    base = {"case": case, "family": "car-to-car rear", "kind": "aeb", "speed_kmh": speed, "aeb": aeb,
            "status": "done", "avoided": False, "relative_impact_kmh": 20.0, "band": "red", "meets": None}
    return {**base, **kw}


CASES = [
    {"id": "CCRs-100", "family": "car-to-car rear", "kind": "aeb", "label": "CCRs 100 %"},
    {"id": "CCRs-FCW", "family": "car-to-car rear", "kind": "fcw", "label": "CCRs FCW 100 %"},
]
CELLS = [
    cell("CCRs-100", 20.0, True, avoided=True, relative_impact_kmh=0.0, band="green", meets=True),
    cell("CCRs-100", 20.0, False),
    cell("CCRs-100", 50.0, True, relative_impact_kmh=12.0, band="orange", meets=False),
    cell("CCRs-FCW", 50.0, False, kind="fcw", fcw_ttc_s=1.2, band="red", meets=False),
]


def test_family_grid_puts_aeb_on_and_off_side_by_side_and_fcw_across_both() -> None:
    html = family_grid("car-to-car rear", CASES, CELLS)
    assert html.count('<th class="sp" colspan="2">') == 2  # 20 and 50 km/h
    row = html.split("CCRs 100 %")[1].split("</tr>")[0]
    assert row.index(COLOURS["green"]) < row.index(COLOURS["red"])  # on, then off
    assert "✓" in row and "12 ✗" in row  # avoided; missed criterion marked
    fcw = html.split("CCRs FCW 100 %")[1].split("</tr>")[0]
    assert 'colspan="2"' in fcw and "1.20 s ✗" in fcw
    assert family_grid("pedestrian", CASES, CELLS) == ""


def test_page_has_legend_points_failures_and_table() -> None:
    card = {"meta": {"detector": "gt"}, "cases": CASES, "cells": CELLS,
            "families": {"car-to-car rear": {"points": 3.0, "max_points": 6.0, "share": 0.5, "cells": 3}},
            "criteria": {"avoid_up_to_kmh": 40.0, "car_50_max_relative_kmh": 5.0, "fcw_min_ttc_s": 1.7},
            "bands": [{"band": "green", "min_reduction": 1.0, "points": 1.0, "meaning": "avoided"},
                      {"band": "yellow", "min_reduction": 0.75, "points": 0.75}],
            "counts": {"cells": 4, "done": 4, "failed_runs": 0, "criteria_failed": 2},
            "failures": [{"case": "CCRs-100", "speed_kmh": 50.0, "aeb": True, "relative_impact_kmh": 12.0,
                          "fcw_ttc_s": None}],
            "table": [{"case": "CCRs-100", "speed_kmh": 20.0, "aeb": True}]}
    page = render_ncap(card)
    assert page.startswith("<!DOCTYPE html>") and "Euro NCAP AEB scorecard" in page
    assert "reduction ≥ 75%" in page and "Cells that miss the criteria" in page and "All cells" in page
