"""A small HTML kit for self-contained report pages: escaping, number formatting, tables,
inline images and figures (base64), matplotlib on the Agg backend, and the page shell with its CSS.

Every page lookahead writes (run, suite, sweep) is built from these, so they look alike and
open offline as one file.
"""

from __future__ import annotations

import base64
import html
import io
import json

from lookahead.tools.sinks.rundir import NEVER

REPORT_FILE = "report.html"

CSS = """
body{font-family:system-ui,-apple-system,Segoe UI,Roboto,sans-serif;margin:24px auto;max-width:1200px;
color:#202124;padding:0 16px}
h1{font-size:24px;margin-bottom:4px}h2{font-size:18px;margin-top:28px;border-bottom:1px solid #dadce0;
padding-bottom:4px}h3{font-size:15px;margin:14px 0 6px}
.sub{color:#5f6368;margin-top:0}
table{border-collapse:collapse;margin:6px 0 12px;font-size:13px}
th,td{border:1px solid #dadce0;padding:3px 8px;text-align:right}th{background:#f1f3f4}
td.l,th.l{text-align:left}
.pass{background:#e6f4ea;color:#137333}.fail{background:#fce8e6;color:#c5221f}
.cards{display:flex;flex-wrap:wrap;gap:10px;margin:12px 0}
.card{border:1px solid #dadce0;border-radius:8px;padding:8px 12px;min-width:120px}
.card .v{font-size:20px;font-weight:600}.card .k{font-size:12px;color:#5f6368}
.grid{display:flex;flex-wrap:wrap;gap:16px;align-items:flex-start}
.sec{flex:0 1 auto}
img.fig{max-width:100%;border:1px solid #eee}
.frames{display:flex;flex-wrap:wrap;gap:8px}
.frames figure{margin:0;flex:1 1 360px;max-width:32%}.frames img{width:100%}
figcaption{font-size:12px;color:#5f6368}
.muted{color:#9aa0a6}
"""


def pyplot():
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


def png_b64(fig) -> str:
    """Base64 PNG of a matplotlib figure (closed afterwards)."""
    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=100, bbox_inches="tight")
    pyplot().close(fig)
    return base64.b64encode(buf.getvalue()).decode("ascii")


def escape(x: object) -> str:
    return html.escape(str(x), quote=True)


def fmt(v: object) -> str:
    if v is None:
        return "—"
    if isinstance(v, bool):
        return "yes" if v else "no"
    if isinstance(v, float):
        if abs(v) >= NEVER:
            return "never"
        return f"{v:.0f}" if abs(v) >= 1000 else f"{v:.3g}"
    if isinstance(v, dict | list):
        return json.dumps(v, separators=(", ", ": "))
    return str(v)


def img(b64: str | None, alt: str) -> str:
    if b64 is None:
        return f'<p class="muted">{escape(alt)}: no data</p>'
    return f'<img class="fig" alt="{escape(alt)}" src="data:image/png;base64,{b64}">'


def align(value: object, column: int) -> str:
    """CSS class: text left, numbers right."""
    numeric = value is None or (isinstance(value, int | float) and not isinstance(value, bool))
    return "" if numeric and column > 0 else "l"


def table(header: list[str], rows: list[list[object]], classes: list[str] | None = None) -> str:
    first = rows[0] if rows else [None] * len(header)
    head = "".join(f'<th class="{align(c, i)}">{escape(h)}</th>' for i, (h, c) in enumerate(zip(header, first, strict=True)))
    body = []
    for k, row in enumerate(rows):
        cls = f' class="{classes[k]}"' if classes and classes[k] else ""
        cells = "".join(f'<td class="{align(c, i)}">{escape(fmt(c))}</td>' for i, c in enumerate(row))
        body.append(f"<tr{cls}>{cells}</tr>")
    return f"<table><tr>{head}</tr>{''.join(body)}</table>"


def confusion_table(confusion: object, title: str = "") -> str:
    """A confusion matrix as an HTML table (rows truth, columns predicted; ``{labels, matrix}``),
    each cell shaded by its share of the row, the diagonal green; the row totals last. Empty for
    a missing or malformed matrix (a hand-edited ``metrics.json``)."""
    if not isinstance(confusion, dict):
        return ""
    labels, m = confusion.get("labels"), confusion.get("matrix")
    n = len(labels) if isinstance(labels, list) else 0
    if not n or not (isinstance(m, list) and len(m) == n and all(
            isinstance(r, list) and len(r) == n and all(isinstance(v, int | float) and not isinstance(v, bool) for v in r)
            for r in m)):
        return ""
    head = "".join(f'<th>{escape(lab)}</th>' for lab in labels)
    body = []
    for i, (lab, r) in enumerate(zip(labels, m, strict=True)):
        total = sum(r)
        cells = []
        for j, v in enumerate(r):
            share = v / total if total else 0.0
            colour = "19,115,51" if i == j else "197,34,31"
            style = f' style="background:rgba({colour},{0.45 * share:.2f})"' if v else ""
            cells.append(f"<td{style}>{escape(fmt(v))}</td>")
        body.append(f'<tr><th class="l">{escape(lab)}</th>{"".join(cells)}<td class="muted">{escape(fmt(total))}</td></tr>')
    caption = f"<h3>{escape(title)}</h3>" if title else ""
    return (f'<div class="sec">{caption}<table><tr><th class="l">truth \\ predicted</th>{head}'
            f'<th>n</th></tr>{"".join(body)}</table></div>')


def flat_rows(d: dict, prefix: str = "") -> list[list[object]]:
    """[key path, value] rows of a nested dict, depth first (``a / b / c``); lists of dicts are
    indexed (``a / 0 / b``), other lists stay one value. Renders a section of any shape."""
    rows: list[list[object]] = []
    for k, v in d.items():
        key = f"{prefix}{k}"
        if isinstance(v, dict):
            rows += flat_rows(v, f"{key} / ") if v else [[key, None]]
        elif isinstance(v, list) and v and all(isinstance(x, dict) for x in v):
            for i, x in enumerate(v):
                rows += flat_rows(x, f"{key} / {i} / ")
        else:
            rows.append([key, v])
    return rows


def nested_tables(d: dict) -> str:
    """One table of a dict's top-level scalars, then one titled table per nested part
    (``flat_rows``): a metrics section whose shape the page does not know."""
    scalars = [[k, v] for k, v in d.items() if not isinstance(v, dict) and not (
        isinstance(v, list) and v and all(isinstance(x, dict) for x in v))]
    out = [f'<div class="sec">{table(["metric", "value"], scalars)}</div>'] if scalars else []
    for k, v in d.items():
        if [k, v] in scalars:
            continue
        rows = flat_rows(v) if isinstance(v, dict) else flat_rows({str(i): x for i, x in enumerate(v)})
        out.append(f'<div class="sec"><h3>{escape(k)}</h3>{table(["metric", "value"], rows)}</div>')
    return f'<div class="grid">{"".join(out)}</div>'


def figure(alt: str, mime: str, data: bytes, caption: str) -> str:
    b64 = base64.b64encode(data).decode("ascii")
    return (f'<figure><img alt="{escape(alt)}" src="data:{mime};base64,{b64}">'
            f"<figcaption>{escape(caption)}</figcaption></figure>")


def page(title: str, body: str) -> str:
    return (f'<!DOCTYPE html>\n<html lang="en"><head><meta charset="utf-8"><title>{escape(title)}</title>'
            f"<style>{CSS}</style></head><body>{body}</body></html>\n")


def row(first: str, cells: list[tuple[object, str]], last: str = "", style: str = "") -> str:
    """A table row: raw HTML first and last cells around escaped, formatted values."""
    tds = "".join(f'<td class="{cls}">{escape(fmt(v))}</td>' for v, cls in cells)
    return f'<tr{style}><td class="l">{first}</td>{tds}<td class="l">{last}</td></tr>'
