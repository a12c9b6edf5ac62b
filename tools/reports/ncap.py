"""The Euro NCAP scorecard page: ``OUT/ncap.html`` from the scorecard dict of ``tools.runs.ncap``.

One grid per family (car-to-car rear, pedestrian, cyclist): a row per test case, a column pair
per ego speed (km/h) with AEB on and AEB off side by side. An AEB cell shows the relative impact
speed (km/h; ✓ when avoided) on its band's colour; an FCW cell (a driver model, no AEB) spans the
pair and shows the true TTC (s) at the first warning, green when >= the criterion. Then the
family points, the cells that miss the acceptance criteria, and the plain table of every cell.
Same self-contained style as the other pages (``tools.reports.html``).
"""

from __future__ import annotations

from pathlib import Path

from lookahead.tools.reports.html import escape, fmt, page, table

NCAP_HTML = "ncap.html"

COLOURS = {"green": "#57bb8a", "yellow": "#ffd666", "orange": "#f6a04d", "brown": "#a1683a", "red": "#e06666",
           None: "#eeeeee"}
_DARK = {"brown", "red"}
NCAP_CSS = """
table.ncap td.c{min-width:34px;text-align:center;font-size:12px}
table.ncap th.sp{text-align:center}
.legend span{display:inline-block;padding:2px 8px;margin-right:4px;border-radius:3px;font-size:12px}
"""


def _cell_html(cell: dict | None, colspan: int = 1) -> str:
    span = f' colspan="{colspan}"' if colspan > 1 else ""
    if cell is None:
        return f'<td class="c muted"{span}></td>'
    if cell["status"] != "done":
        return f'<td class="c" style="background:#ccc"{span} title="{escape(cell.get("error") or "")}">err</td>'
    band = cell.get("band")
    fg = "#fff" if band in _DARK else "#202124"
    if cell["kind"] == "fcw":
        text = "no FCW" if cell.get("fcw_ttc_s") is None else f"{cell['fcw_ttc_s']:.2f} s"
        tip = f"first warning at true TTC {fmt(cell.get('fcw_ttc_s'))} s; impact {fmt(cell.get('relative_impact_kmh'))} km/h"
    else:
        text = "✓" if cell.get("avoided") else f"{cell.get('relative_impact_kmh') or 0:.0f}"
        tip = (f"relative impact {fmt(cell.get('relative_impact_kmh'))} km/h, ego {fmt(cell.get('impact_speed_kmh'))} "
               f"km/h, at {fmt(cell.get('impact_pct'))} % of the width, false activations "
               f"{fmt(cell.get('false_activations'))}")
    mark = " ✗" if cell.get("meets") is False else ""
    return (f'<td class="c"{span} style="background:{COLOURS.get(band, "#eee")};color:{fg}" '
            f'title="{escape(tip)}">{escape(text + mark)}</td>')


def family_grid(family: str, cases: list[dict], cells: list[dict]) -> str:
    """The grid of one family: rows = cases, columns = ego speed x (AEB on, AEB off)."""
    mine = [c for c in cells if c["family"] == family]
    if not mine:
        return ""
    speeds = sorted({c["speed_kmh"] for c in mine})
    by = {(c["case"], c["speed_kmh"], c["aeb"]): c for c in mine}
    head1 = '<tr><th class="l" rowspan="2">case</th>' + "".join(
        f'<th class="sp" colspan="2">{s:g}</th>' for s in speeds) + "</tr>"
    head2 = "<tr>" + "<th>on</th><th>off</th>" * len(speeds) + "</tr>"
    rows = []
    for case in cases:
        if case["family"] != family or not any(c["case"] == case["id"] for c in mine):
            continue
        tds = []
        for s in speeds:
            if case["kind"] == "fcw":
                tds.append(_cell_html(by.get((case["id"], s, False)), colspan=2))
            else:
                tds += [_cell_html(by.get((case["id"], s, True))), _cell_html(by.get((case["id"], s, False)))]
        rows.append(f'<tr><td class="l">{escape(case["label"])}</td>{"".join(tds)}</tr>')
    return (f"<h3>{escape(family)} — ego speed (km/h), AEB on | off</h3>"
            f'<table class="ncap">{head1}{head2}{"".join(rows)}</table>')


def legend(card: dict) -> str:
    crit = card.get("criteria", {})
    spans = []
    for b in card.get("bands", []):
        lo = b.get("min_reduction")
        what = b.get("meaning") or (f"reduction ≥ {lo:.0%}" if lo is not None else "less")
        fg = "#fff" if b["band"] in _DARK else "#202124"
        spans.append(f'<span style="background:{COLOURS[b["band"]]};color:{fg}">{escape(b["band"])}: {escape(what)}'
                     f' ({b["points"]:g} pt)</span>')
    return (f'<p class="legend">{"".join(spans)}</p><p class="sub">AEB cells: relative impact speed (km/h) on the '
            f"band of its reduction against the relative speed at the start; ✓ avoided; ✗ misses the criterion "
            f"(avoided up to {fmt(crit.get('avoid_up_to_kmh'))} km/h; car-to-car at 50 km/h at most "
            f"{fmt(crit.get('car_50_max_relative_kmh'))} km/h). FCW cells: true TTC at the first warning, green "
            f"when ≥ {fmt(crit.get('fcw_min_ttc_s'))} s. AEB-off cells are the baseline (coloured, not scored). "
            f"Hover a cell for details.</p>")


def render_ncap(card: dict) -> str:
    """The whole page of a scorecard."""
    meta = card.get("meta", {})
    counts = card.get("counts", {})
    parts = [f"<style>{NCAP_CSS}</style>", "<h1>Euro NCAP AEB scorecard</h1>",
             f'<p class="sub">detector {escape(fmt(meta.get("detector")))}, render {escape(fmt(meta.get("render")))}, '
             f'AEB {escape(fmt(meta.get("aeb")))}; {counts.get("done", 0)} of {counts.get("cells", 0)} cells run, '
             f'{counts.get("failed_runs", 0)} failed runs, {counts.get("criteria_failed", 0)} cells miss the criteria. '
             f"See docs/ncap.md.</p>", legend(card), "<h2>Grids</h2>"]
    families = list(card.get("families", {}))
    parts += [family_grid(f, card.get("cases", []), card.get("cells", [])) for f in families]
    fam_rows = [[f, v.get("points"), v.get("max_points"), v.get("share"), v.get("cells")]
                for f, v in card.get("families", {}).items()]
    parts += ["<h2>Points</h2>", table(["family", "points", "of", "share", "scored cells"], fam_rows)]
    fails = card.get("failures", [])
    parts.append("<h2>Cells that miss the criteria</h2>")
    parts.append(table(["case", "speed km/h", "aeb", "relative impact km/h", "FCW TTC s"],
                       [[f["case"], f["speed_kmh"], f["aeb"], f["relative_impact_kmh"], f["fcw_ttc_s"]] for f in fails])
                 if fails else '<p class="muted">none</p>')
    rows = card.get("table") or []
    if rows:
        keys = list(rows[0])
        parts += ["<h2>All cells</h2>", table(keys, [[r.get(k) for k in keys] for r in rows])]
    return page("Euro NCAP AEB scorecard", "".join(parts))


def write_ncap_report(path: Path, card: dict) -> Path:
    """Write the scorecard page to ``path``."""
    path.write_text(render_ncap(card), encoding="utf-8")
    return path
