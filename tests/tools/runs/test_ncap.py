"""The Euro NCAP catalogue and the ``lookahead ncap`` scorecard: every catalogue file loads, the
bands and criteria grade cells as documented, and a small slice (CCRs 100 % at 20 and 40 km/h,
AEB on and off, gt detector) runs end to end through the command line."""

from __future__ import annotations

import json
from pathlib import Path

import pytest
import yaml

from lookahead.sim.scenario import load_scenario
from lookahead.tools.runs.ncap import (
    CASES,
    FAMILY_POINTS,
    NCAP_DIR,
    TARGET,
    Cell,
    NcapError,
    band_of,
    case_variants,
    grade,
    select_cases,
)
from lookahead.tools.runs.sweep import load_sweep

FILES = sorted(NCAP_DIR.glob("*.yaml"))


def is_sweep(path: Path) -> bool:
    return "scenario" in yaml.safe_load(path.read_text())


def test_every_catalogue_file_validates_and_every_sweep_is_a_case() -> None:
    sweeps = [p for p in FILES if is_sweep(p)]
    for p in FILES:
        if not is_sweep(p):
            assert any(a.id == TARGET for a in load_scenario(p).actors), p
    assert sorted(p.stem for p in sweeps) == sorted(c.sweep for c in CASES)
    for case in CASES:
        spec, _, variants = load_sweep(NCAP_DIR / f"{case.sweep}.yaml")
        assert spec.name == case.id and case.family in FAMILY_POINTS and variants, case
        for v in variants:
            assert any(a.id == TARGET for a in v.scenario.actors)
            if case.kind == "fcw":  # a warning judged by its outcome: driver model, no AEB
                assert v.scenario.ego.driver is not None and not v.scenario.ego.aeb
        if case.kind == "aeb":
            assert {v.params["ego.aeb"] for v in variants} == {False, True}
    assert sum(len(load_sweep(NCAP_DIR / f"{c.sweep}.yaml")[2]) for c in CASES) == 198


def test_selection_by_test_code_case_id_aeb_and_speed() -> None:
    assert [c.id for c in select_cases(["ccrs"])] == ["CCRs-50", "CCRs-75", "CCRs-100", "CCRs-FCW"]
    assert [c.id for c in select_cases(["CPNA-25-night", "CBLA"])] == ["CPNA-25-night", "CBLA-50", "CBLA-FCW"]
    with pytest.raises(NcapError, match="unknown case 'xyz'"):
        select_cases(["xyz"])
    case = select_cases(["CCRs-100"])[0]
    _, variants = case_variants(case, aeb="on", speeds=[20, 40], detector="gt")
    assert sorted(round(v.scenario.ego.speed * 3.6) for v in variants) == [20, 40]
    assert all(v.scenario.ego.aeb and v.scenario.perception.detector.kind == "gt" for v in variants)


def cell(**kw) -> Cell:
    base = {"case": "CCRs-100", "test": "CCRs", "family": "car-to-car rear", "kind": "aeb", "speed_kmh": 50.0,
            "aeb": True, "status": "done", "avoided": False, "reference_kmh": 50.0}
    return Cell(**{**base, **kw})


def test_bands_points_and_criteria() -> None:
    assert band_of(True, None) == ("green", 1.0)
    assert [band_of(False, r)[0] for r in (0.9, 0.6, 0.3, 0.1, None)] == ["yellow", "orange", "brown", "red", "red"]
    cells = [
        cell(relative_impact_kmh=4.0),  # car-to-car at 50: at most 5 km/h passes
        cell(relative_impact_kmh=6.0, case="CCRs-75"),
        cell(speed_kmh=40.0, relative_impact_kmh=10.0, case="CCRs-50", reference_kmh=40.0),  # not avoided at 40
        cell(kind="fcw", aeb=False, case="CCRs-FCW", fcw_ttc_s=1.5, avoided=True),
        cell(case="CCRb-12m-6", reference_kmh=None, relative_impact_kmh=9.0, speed_kmh=50.0),
        cell(case="CCRb-12m-6", reference_kmh=None, relative_impact_kmh=36.0, speed_kmh=50.0, aeb=False),
    ]
    grade(cells)
    assert [c.meets for c in cells[:4]] == [True, False, False, False]
    assert cells[0].band == "yellow" and cells[0].points == 0.75 and cells[3].band == "red"
    assert cells[2].reduction == 0.75 and cells[2].band == "yellow"
    assert cells[4].reference_kmh == 36.0 and cells[4].reduction == 0.75  # CCRb: against its AEB-off twin
    assert cells[5].points is None  # the AEB-off baseline is coloured, not scored


def test_ncap_command_runs_a_slice_end_to_end(lookahead, tmp_path: Path, capsys) -> None:
    out = tmp_path / "ncap"
    code = lookahead("ncap", "--out", out, "--detector", "gt", "--only", "CCRs-100", "--speeds", "20,40",
                     "--workers", "1")
    assert code == 0, capsys.readouterr().err
    card = json.loads((out / "ncap.json").read_text())
    assert {"meta", "cases", "families", "criteria", "bands", "counts", "failures", "cells", "table"} <= set(card)
    assert card["counts"]["cells"] == 4 and card["counts"]["failed_runs"] == 0
    assert set(card["table"][0]) >= {"case", "speed_kmh", "aeb", "impact_speed_kmh", "relative_impact_kmh",
                                     "avoided", "fcw_ttc_s", "false_activations"}
    cells = {(c["speed_kmh"], c["aeb"]): c for c in card["cells"]}
    on, off = cells[(20.0, True)], cells[(20.0, False)]
    assert on["avoided"] and on["band"] == "green" and on["points"] == 1.0 and on["meets"] is True
    assert not off["avoided"] and off["collided_with"] == TARGET
    assert off["relative_impact_kmh"] == pytest.approx(20.0, abs=0.5) and off["impact_pct"] == pytest.approx(50, abs=1)
    assert card["families"]["car-to-car rear"]["cells"] == 2
    page = (out / "ncap.html").read_text()
    assert 'class="ncap"' in page and "CCRs 100 %" in page and "car-to-car rear" in page
    assert (out / "CCRs-100" / "summary.json").is_file()
    err = capsys.readouterr().err
    assert "ncap: 4 of 4 cells done" in err


def test_ncap_command_rejects_unknown_cases_in_one_line(lookahead, tmp_path: Path, capsys) -> None:
    assert lookahead("ncap", "--out", tmp_path, "--only", "CCRz") == 2
    err = capsys.readouterr().err
    assert "unknown case 'ccrz'" in err and "Traceback" not in err
