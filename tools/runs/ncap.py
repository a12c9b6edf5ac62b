"""The Euro NCAP AEB scorecard: run the ``scenarios/ncap`` catalogue and score every cell.

The catalogue is one sweep file per test case (``CASES``: CCRs 50 %, CPNA-25 ...), each a grid
of ego speeds, AEB on and off (FCW cases: AEB off and a driver who brakes for the first
warning). ``run_ncap`` runs the selected cases with ``tools.runs.sweep.run_sweep`` into
``OUT/<case id>/`` (a re-run skips done variants), then ``score_ncap`` reads each variant's run
directory into a cell (``Cell``) and writes ``OUT/ncap.json`` and ``OUT/ncap.html``
(``tools.reports.ncap``). docs/ncap.md explains the cases, bands and weights.

Cell values (units): speeds in km/h; ``impact_speed_kmh`` is the ego's speed at the first
collision, ``relative_impact_kmh`` the closing speed along the ego's axis then
(``sim.ego.Collision.relative_speed``), both 0 when the run avoided every collision;
``impact_pct`` is where the target's centre was on the ego's front at that moment, in % of the
ego's width from its left side (the ``start.impact`` convention); ``fcw_ttc_s`` is the true TTC
to the target at the first ``fcw`` / ``critical`` alert on a track of it.
"""

from __future__ import annotations

import json
import logging
import math
from collections.abc import Callable
from dataclasses import asdict, dataclass, replace
from pathlib import Path

from lookahead.sim.catalogue import SCENARIOS
from lookahead.sim.scenario import ScenarioError, with_detector
from lookahead.tools.reports.ncap import NCAP_HTML, write_ncap_report
from lookahead.tools.runs.sweep import Variant, load_sweep, new_pool, run_sweep
from lookahead.tools.scoring.intent import evaluate_danger, load_intent_run
from lookahead.tools.sinks.rundir import RunDir, read_summary

log = logging.getLogger(__name__)

NCAP_DIR = SCENARIOS / "ncap"
NCAP_JSON = "ncap.json"
TARGET = "target"  # the actor id of every case's target
KMH = 3.6  # km/h per m/s
AEB_CHOICES = ("on", "off", "both")

CAR, PED, CYC = "car-to-car rear", "pedestrian", "cyclist"


@dataclass(frozen=True)
class Case:
    """One test case: a row of the scorecard and one sweep file ``scenarios/ncap/<sweep>.yaml``."""

    id: str  # the sweep's name, e.g. CCRs-50
    test: str  # the protocol's scenario code, e.g. CCRs
    family: str
    kind: str  # aeb | fcw
    sweep: str
    label: str


CASES: tuple[Case, ...] = (
    Case("CCRs-50", "CCRs", CAR, "aeb", "ccrs_50", "CCRs 50 %"),
    Case("CCRs-75", "CCRs", CAR, "aeb", "ccrs_75", "CCRs 75 %"),
    Case("CCRs-100", "CCRs", CAR, "aeb", "ccrs_100", "CCRs 100 %"),
    Case("CCRs-FCW", "CCRs", CAR, "fcw", "ccrs_fcw", "CCRs FCW 100 %"),
    Case("CCRm-100", "CCRm", CAR, "aeb", "ccrm_100", "CCRm 100 %"),
    Case("CCRb-12m-2", "CCRb", CAR, "aeb", "ccrb_12_2", "CCRb 12 m −2 m/s²"),
    Case("CCRb-12m-6", "CCRb", CAR, "aeb", "ccrb_12_6", "CCRb 12 m −6 m/s²"),
    Case("CCRb-40m-2", "CCRb", CAR, "aeb", "ccrb_40_2", "CCRb 40 m −2 m/s²"),
    Case("CCRb-40m-6", "CCRb", CAR, "aeb", "ccrb_40_6", "CCRb 40 m −6 m/s²"),
    Case("CPNA-25", "CPNA", PED, "aeb", "cpna_25", "CPNA 25 %"),
    Case("CPNA-75", "CPNA", PED, "aeb", "cpna_75", "CPNA 75 %"),
    Case("CPNA-25-night", "CPNA", PED, "aeb", "cpna_25_night", "CPNA 25 % night"),
    Case("CPFA-50", "CPFA", PED, "aeb", "cpfa_50", "CPFA 50 %"),
    Case("CPNC-50", "CPNC", PED, "aeb", "cpnc_50", "CPNC 50 %"),
    Case("CPLA-25", "CPLA", PED, "aeb", "cpla_25", "CPLA 25 %"),
    Case("CPLA-50", "CPLA", PED, "aeb", "cpla_50", "CPLA 50 %"),
    Case("CPLA-25-night", "CPLA", PED, "aeb", "cpla_25_night", "CPLA 25 % night"),
    Case("CPLA-FCW", "CPLA", PED, "fcw", "cpla_fcw", "CPLA FCW 50 %"),
    Case("CBNA-50", "CBNA", CYC, "aeb", "cbna_50", "CBNA 50 %"),
    Case("CBNAO-50", "CBNAO", CYC, "aeb", "cbnao_50", "CBNAO 50 %"),
    Case("CBFA-50", "CBFA", CYC, "aeb", "cbfa_50", "CBFA 50 %"),
    Case("CBLA-50", "CBLA", CYC, "aeb", "cbla_50", "CBLA 50 %"),
    Case("CBLA-FCW", "CBLA", CYC, "fcw", "cbla_fcw", "CBLA FCW 50 %"),
)

#: Points of each family in the scorecard (docs/ncap.md, "Weights"): provisional, as we read the
#: Euro NCAP Assessment Protocols (Safety Assist for car-to-car, VRU for pedestrian / cyclist).
FAMILY_POINTS: dict[str, float] = {CAR: 6.0, PED: 9.0, CYC: 8.0}

#: Colour bands of an AEB cell by the relative-speed reduction r = 1 - v_impact / v_reference:
#: (colour, lowest r, share of the cell's points). Avoided (no collision) is always green.
BANDS: tuple[tuple[str, float, float], ...] = (
    ("yellow", 0.75, 0.75), ("orange", 0.50, 0.50), ("brown", 0.25, 0.25), ("red", -math.inf, 0.0),
)
FCW_MIN_TTC_S = 1.7  # a warning counts when the true TTC at its first frame is at least this
AVOID_UP_TO_KMH = 40.0  # criterion: AEB cases up to this ego speed are avoided
CAR_50_MAX_REL_KMH = 5.0  # criterion: car-to-car at 50 km/h, relative impact speed at most this
#: The columns of the scorecard's plain ``table`` of cells.
TABLE_KEYS = ("case", "speed_kmh", "aeb", "impact_speed_kmh", "relative_impact_kmh", "avoided", "fcw_ttc_s",
              "false_activations", "impact_pct", "band")


class NcapError(ScenarioError):
    """A bad ``ncap`` option (unknown case, speed list); ``str()`` is one line."""


@dataclass
class Cell:
    """One variant of one case: a grid cell of the scorecard (units in the module docstring)."""

    case: str
    test: str
    family: str
    kind: str
    speed_kmh: float
    aeb: bool
    status: str  # done | failed
    collision: bool | None = None
    collided_with: str | None = None
    avoided: bool | None = None
    impact_speed_kmh: float | None = None
    relative_impact_kmh: float | None = None
    reference_kmh: float | None = None  # the relative speed the reduction is measured against
    reduction: float | None = None  # 1 - relative impact / reference (1 = avoided)
    impact_pct: float | None = None
    fcw_ttc_s: float | None = None
    false_activations: int | None = None
    band: str | None = None
    points: float | None = None  # share of the cell's points, 0..1 (scored cells only)
    meets: bool | None = None  # the acceptance criterion (None: none applies)
    dir: str | None = None
    error: str | None = None


# --------------------------------------------------------------------------- selecting


def select_cases(only: list[str] | None = None) -> list[Case]:
    """The cases named by ``only`` (case ids or test codes, case-insensitive); all when empty."""
    if not only:
        return list(CASES)
    wanted = {w.strip().lower() for w in only if w.strip()}
    known = {c.id.lower() for c in CASES} | {c.test.lower() for c in CASES}
    unknown = sorted(wanted - known)
    if unknown:
        raise NcapError(f"--only: unknown case {unknown[0]!r}; expected test codes "
                        f"({', '.join(dict.fromkeys(c.test for c in CASES))}) or case ids (CCRs-50, CPNA-25-night ...)")
    return [c for c in CASES if c.id.lower() in wanted or c.test.lower() in wanted]


def parse_speeds(text: str | None) -> list[float] | None:
    """``--speeds 20,40`` as km/h values (None: every speed of the grids)."""
    if text is None:
        return None
    try:
        speeds = [float(s) for s in text.split(",") if s.strip()]
    except ValueError:
        raise NcapError(f"--speeds {text!r}: expected km/h values separated by commas, e.g. 20,40") from None
    if not speeds:
        raise NcapError("--speeds: expected at least one speed (km/h)")
    return speeds


def kmh(v: float) -> float:
    """m/s to km/h, rounded to 0.1 (the grids' speeds are whole km/h)."""
    return round(float(v) * KMH, 1)


def case_variants(case: Case, aeb: str = "both", speeds: list[float] | None = None,
                  detector: str | None = None) -> tuple[Path, list[Variant]]:
    """(sweep file, its variants) of ``case``, filtered by AEB (on | off | both; FCW cases run
    whatever ``aeb`` says: they have no AEB) and ego speed (km/h, ±0.5), with ``detector``."""
    path = NCAP_DIR / f"{case.sweep}.yaml"
    _, _, variants = load_sweep(path)
    if case.kind == "aeb" and aeb != "both":
        variants = [v for v in variants if bool(v.params.get("ego.aeb")) == (aeb == "on")]
    if speeds is not None:
        variants = [v for v in variants if any(abs(kmh(v.scenario.ego.speed) - s) <= 0.5 for s in speeds)]
    if detector is not None:
        variants = [replace(v, scenario=with_detector(v.scenario, detector)) for v in variants]
    return path, variants


# --------------------------------------------------------------------------- scoring one cell


def band_of(avoided: bool, reduction: float | None) -> tuple[str, float]:
    """(colour, share of points) of an AEB cell."""
    if avoided:
        return "green", 1.0
    r = -math.inf if reduction is None else reduction
    return next((name, pts) for name, lo, pts in BANDS if r >= lo)


def first_collision(rd: RunDir) -> tuple[dict | None, dict | None]:
    """(first collision record, the ground truth of its frame) of a run, or (None, None)."""
    for rec in rd.ticks:
        if rec.get("collisions"):
            return rec["collisions"][0], rec.get("ground_truth") or {}
    return None, None


def lateral_of(gt: dict, name: str) -> float | None:
    """Ego-frame lateral (m, left +) of the centre of actor ``name`` in a ground-truth record."""
    names = gt.get("name") or []
    if name not in names:
        return None
    box = (gt.get("box3d") or [])[names.index(name)]
    return float(box[1]) if box else None


def fcw_ttc(rd: RunDir, target: str = TARGET) -> float | None:
    """True TTC (s) to ``target`` at the first ``fcw`` / ``critical`` alert on a track of it."""
    run = load_intent_run(rd)
    evaluate_danger(run)  # tags each raised alert with its ground-truth actor
    ids = [a for a, n in run.names.items() if n == target]
    if not ids:
        return None
    mine = [a for a in run.alerts if a.get("kind") in ("fcw", "critical") and a.get("actor") == ids[0]]
    if not mine:
        return None
    first = min(mine, key=lambda a: a["t"])
    ttc = run.gt_ttc[ids[0]].get(first["frame"], math.inf)
    return round(ttc, 3) if math.isfinite(ttc) else None


def target_speed_along(scenario: dict) -> float:
    """The target's initial speed along the ego's axis (m/s) from run.json's scenario."""
    for a in scenario.get("actors") or []:
        if a.get("id") == TARGET:
            return float(a.get("speed") or 0.0) * math.cos(math.radians(float(a.get("heading") or 0.0)))
    return 0.0


def read_cell(case: Case, entry: dict, out: Path) -> Cell:
    """The cell of one variant (a ``summary.json`` entry of the case's sweep directory ``out``)."""
    params = entry.get("params") or {}
    cell = Cell(case=case.id, test=case.test, family=case.family, kind=case.kind,
                speed_kmh=kmh(params.get("ego.speed", 0.0)), aeb=bool(params.get("ego.aeb", False)),
                status=entry.get("status", "failed"), dir=str(out / entry["dir"]) if entry.get("dir") else None,
                error=entry.get("error"))
    if cell.status != "done" or cell.dir is None:
        return cell
    rd = RunDir(cell.dir)
    metrics = rd.read_metrics()
    scenario = rd.run.get("scenario") or {}
    hit, gt = first_collision(rd)
    cell.collision = hit is not None
    cell.avoided = not cell.collision
    cell.false_activations = (metrics.get("aeb") or {}).get("false_activations")
    ref = max(float(params.get("ego.speed", 0.0)) - target_speed_along(scenario), 0.0) * KMH
    cell.reference_kmh = round(ref, 2) if ref >= 1.0 else None  # CCRb: set from the AEB-off twin
    if hit is not None:
        cell.collided_with = hit.get("name")
        cell.impact_speed_kmh = round(float(hit["ego_speed"]) * KMH, 2)
        cell.relative_impact_kmh = round(abs(float(hit["relative_speed"])) * KMH, 2)
        y = lateral_of(gt, hit.get("name", TARGET))
        width = float((scenario.get("ego") or {}).get("width") or 1.85)
        cell.impact_pct = None if y is None else round((0.5 - y / width) * 100.0, 1)
    else:
        cell.impact_speed_kmh = cell.relative_impact_kmh = 0.0
    if case.kind == "fcw":
        cell.fcw_ttc_s = fcw_ttc(rd)
    return cell


def grade(cells: list[Cell]) -> None:
    """Reduction, band, points and the acceptance criterion of every done cell (in place).

    The reference of a CCRb cell (no closing speed at the start) is the relative impact speed
    of its AEB-off twin (same case and speed), else the ego speed."""
    off = {(c.case, c.speed_kmh): c for c in cells if c.status == "done" and not c.aeb}
    for c in cells:
        if c.status != "done":
            continue
        if c.reference_kmh is None:
            twin = off.get((c.case, c.speed_kmh))
            c.reference_kmh = (twin.relative_impact_kmh if twin is not None and twin.relative_impact_kmh
                               else c.speed_kmh)
        rel = c.relative_impact_kmh or 0.0
        c.reduction = 1.0 if c.avoided else round(1.0 - rel / c.reference_kmh, 3) if c.reference_kmh else None
        if c.kind == "fcw":
            warned = c.fcw_ttc_s is not None and c.fcw_ttc_s >= FCW_MIN_TTC_S
            c.band, c.points, c.meets = ("green", 1.0, True) if warned else ("red", 0.0, False)
            continue
        c.band, pts = band_of(bool(c.avoided), c.reduction)
        if not c.aeb:
            continue  # the baseline: coloured, not scored
        c.points = pts
        if c.speed_kmh <= AVOID_UP_TO_KMH + 0.5:
            c.meets = bool(c.avoided)
        elif c.family == CAR and abs(c.speed_kmh - 50.0) <= 0.5:
            c.meets = rel <= CAR_50_MAX_REL_KMH


def family_scores(cells: list[Cell]) -> dict[str, dict]:
    """Per family: scored cells, mean share of points, points out of ``FAMILY_POINTS``."""
    out = {}
    for fam, weight in FAMILY_POINTS.items():
        scored = [c for c in cells if c.family == fam and c.points is not None]
        share = sum(c.points for c in scored) / len(scored) if scored else None
        out[fam] = {"max_points": weight, "cells": len(scored),
                    "share": None if share is None else round(share, 4),
                    "points": None if share is None else round(share * weight, 2)}
    return out


def score_ncap(out: Path, cases: list[Case], meta: dict | None = None) -> dict:
    """Read every case directory under ``out`` into cells, grade them, and return the scorecard."""
    cells: list[Cell] = []
    for case in cases:
        d = out / case.id
        try:
            summary = read_summary(d)
        except (OSError, ValueError):
            log.info("ncap: no summary for %s in %s", case.id, d)
            continue
        for entry in summary.get("variants", {}).values():
            cells.append(read_cell(case, entry, d))
    grade(cells)
    cells.sort(key=lambda c: ([x.id for x in CASES].index(c.case), c.speed_kmh, not c.aeb))
    failures = [c for c in cells if c.meets is False]
    return {
        "meta": meta or {},
        "cases": [asdict(c) for c in cases],
        "families": family_scores(cells),
        "criteria": {"avoid_up_to_kmh": AVOID_UP_TO_KMH, "car_50_max_relative_kmh": CAR_50_MAX_REL_KMH,
                     "fcw_min_ttc_s": FCW_MIN_TTC_S},
        "bands": [{"band": "green", "min_reduction": 1.0, "points": 1.0, "meaning": "avoided"}]
        + [{"band": b, "min_reduction": None if math.isinf(lo) else lo, "points": p} for b, lo, p in BANDS],
        "counts": {"cells": len(cells), "done": sum(c.status == "done" for c in cells),
                   "failed_runs": sum(c.status != "done" for c in cells), "criteria_failed": len(failures)},
        "failures": [{"case": c.case, "speed_kmh": c.speed_kmh, "aeb": c.aeb,
                      "relative_impact_kmh": c.relative_impact_kmh, "fcw_ttc_s": c.fcw_ttc_s} for c in failures],
        "cells": [asdict(c) for c in cells],
    }


def with_table(card: dict) -> dict:
    """``card`` with ``table``: the plain rows of every cell (``TABLE_KEYS``)."""
    card["table"] = [{k: c.get(k) for k in TABLE_KEYS} for c in card["cells"]]
    return card


# --------------------------------------------------------------------------- running


def run_ncap(
    out: Path, detector: str | None = None, render: bool = False, workers: int = 1,
    only: list[str] | None = None, aeb: str = "both", speeds: list[float] | None = None,
    progress: Callable[[dict], None] | None = None, announce: Callable[[Case, int], None] | None = None,
) -> dict:
    """Run the selected cases (``out/<case id>/``, done variants skipped), score them, write
    ``out/ncap.json`` and ``out/ncap.html``; returns the scorecard.

    ``detector`` (gt | onnx | auto) replaces every scenario's detector, ``aeb`` (on | off | both)
    picks the AEB variants, ``speeds`` (km/h) the ego speeds; ``announce(case, n)`` is called
    before a case's ``n`` variants run, ``progress(result)`` after each."""
    if aeb not in AEB_CHOICES:
        raise NcapError(f"--aeb {aeb!r}: expected on, off or both")
    cases = select_cases(only)
    plan = [(c, *case_variants(c, aeb, speeds, detector)) for c in cases]
    plan = [(c, p, v) for c, p, v in plan if v]
    if not plan:
        raise NcapError("nothing to run: no variant of the selected cases matches --aeb / --speeds")
    out = Path(out).resolve()
    out.mkdir(parents=True, exist_ok=True)
    pool = new_pool(workers) if workers > 1 else None
    try:
        for case, path, variants in plan:
            if announce is not None:
                announce(case, len(variants))
            run_sweep(path, out / case.id, workers=1, render=render, variants=variants, report=False,
                      progress=progress, executor=pool)
    finally:
        if pool is not None:
            pool.shutdown()
    meta = {"detector": detector, "render": render, "aeb": aeb, "speeds_kmh": speeds,
            "only": only, "catalogue": str(NCAP_DIR)}
    card = with_table(score_ncap(out, [c for c, _, _ in plan], meta))
    write_ncap(out, card)
    return card


def write_ncap(out: Path, card: dict) -> tuple[Path, Path]:
    """``out/ncap.json`` and ``out/ncap.html`` of a scorecard."""
    path = out / NCAP_JSON
    path.write_text(json.dumps(card, indent=2) + "\n", encoding="utf-8")
    html = write_ncap_report(out / NCAP_HTML, card)
    return path, html
