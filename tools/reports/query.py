"""``lookahead query DB alerts|tracks|objects|summary``: canned reports from a ``SqliteStore`` DB.

* ``alerts``  -- one row per alert event (t s, range m, TTC s, level name, reason).
* ``tracks``  -- one row per (run, track): class, frames, first/last t, min range,
  min TTC (estimator), max risk and the reason text of its first frame at that
  risk (table ``assessments``), the GT actor it followed most.
* ``objects`` -- one row per (run, GT actor): class, frames, first/last seen
  (t in ground truth), min range, min TTC, max risk, first tracked, first alert.
* ``summary`` -- one row per run: frames, end time, collisions, alerts by level, complete.

Output: ``table`` (rich, stdout), ``csv`` (csv module, stdout; inf as ``inf``),
``json`` (a list of objects; NaN -> null, inf -> 1e9 as in ``ticks.jsonl``), formatted here
(``to_csv``, ``to_json``) and printed by the CLI.
The DB is opened read-only (``tools.sinks.store.open_db(create=False)``), also in a
directory this process cannot write (a read-only mount, another user's runs): there SQLite
cannot create the WAL's ``-shm`` file, and the file is read ``immutable=1`` -- only when no
``-wal`` with changes (a writer running, or killed) nor ``-journal`` lies beside it;
otherwise one line says so.
"""

from __future__ import annotations

import csv
import io
import json
import math
import sqlite3
from pathlib import Path

from lookahead.intent.labels import Risk
from lookahead.sim.records import jsonable
from lookahead.tools.sinks.store import StoreError, open_db

WHATS = ("alerts", "tracks", "objects", "summary")
FORMATS = ("table", "csv", "json")
_RISK_COLUMNS = ("level", "max_risk", "max_alert")

_SQL = {
    "alerts": """
        SELECT a.run_id AS run, r.name AS scenario, a.t, a.frame, a.track_id, a.actor_id, a.cls, a.kind,
               a.level, a.range, a.ttc, a.reason
        FROM alerts a JOIN runs r ON r.id = a.run_id {where}
        ORDER BY a.run_id, a.t, a.track_id""",
    "tracks": """
        SELECT t.run_id AS run, t.track_id, MIN(t.cls) AS cls, COUNT(*) AS frames,
               MIN(t.t) AS first_t, MAX(t.t) AS last_t, MIN(t.range) AS min_range,
               MIN(t.ttc) AS min_ttc,
               (SELECT MAX(a.risk) FROM assessments a
                WHERE a.run_id = t.run_id AND a.track_id = t.track_id) AS max_risk,
               (SELECT a.reason FROM assessments a WHERE a.run_id = t.run_id AND a.track_id = t.track_id
                ORDER BY a.risk DESC, a.frame LIMIT 1) AS reason,
               (SELECT s.source_id FROM tracks s
                WHERE s.run_id = t.run_id AND s.track_id = t.track_id AND s.source_id IS NOT NULL
                GROUP BY s.source_id ORDER BY COUNT(*) DESC, s.source_id LIMIT 1) AS actor_id
        FROM tracks t {where}
        GROUP BY t.run_id, t.track_id ORDER BY t.run_id, t.track_id""",
    "objects": """
        SELECT g.run_id AS run, g.actor_id, MIN(g.name) AS name, MIN(g.cls) AS cls,
               MIN(g.subtype) AS subtype, COUNT(*) AS frames, MIN(g.t) AS first_seen,
               MAX(g.t) AS last_seen, MIN(g.range) AS min_range, MIN(g.ttc) AS min_ttc,
               MAX(g.risk) AS max_risk, tr.first_tracked, al.first_alert, al.max_alert
        FROM ground_truth g
        LEFT JOIN (SELECT run_id, source_id, MIN(t) AS first_tracked FROM tracks
                   WHERE source_id IS NOT NULL {and_where} GROUP BY run_id, source_id) tr
               ON tr.run_id = g.run_id AND tr.source_id = g.actor_id
        LEFT JOIN (SELECT run_id, actor_id, MIN(t) AS first_alert, MAX(level) AS max_alert FROM alerts
                   WHERE actor_id IS NOT NULL AND level > 0 {and_where} GROUP BY run_id, actor_id) al
               ON al.run_id = g.run_id AND al.actor_id = g.actor_id
        {where}
        GROUP BY g.run_id, g.actor_id ORDER BY g.run_id, g.actor_id""",
    "summary": """
        SELECT r.id AS run, r.name AS scenario, r.seed, r.started, r.complete,
               (SELECT COUNT(*) FROM frames f WHERE f.run_id = r.id) AS frames,
               (SELECT MAX(f.t) FROM frames f WHERE f.run_id = r.id) AS t_end,
               (SELECT COUNT(*) FROM collisions c WHERE c.run_id = r.id) AS collisions,
               (SELECT COUNT(*) FROM alerts a WHERE a.run_id = r.id AND a.level = 3) AS alerts_high,
               (SELECT COUNT(*) FROM alerts a WHERE a.run_id = r.id AND a.level = 4) AS alerts_critical,
               (SELECT COUNT(*) FROM alerts a WHERE a.run_id = r.id AND a.level = 0) AS alerts_clear
        FROM runs r {where} ORDER BY r.id""",
}
_ALIAS = {"alerts": "a", "tracks": "t", "objects": "g", "summary": "r"}


def fetch(conn: sqlite3.Connection, what: str, run: int | None = None) -> list[dict]:
    """Rows of one report as dicts (risk/level columns as names, floats rounded to 1e-3)."""
    if what not in _SQL:
        raise StoreError(f"unknown report {what!r}: expected one of {', '.join(WHATS)}")
    col = "id" if what == "summary" else "run_id"
    where = "" if run is None else f"WHERE {_ALIAS[what]}.{col} = :run"
    and_where = "" if run is None else "AND run_id = :run"
    cur = conn.execute(_SQL[what].format(where=where, and_where=and_where), {"run": run})
    names = [d[0] for d in cur.description]
    return [_tidy(dict(zip(names, row, strict=True))) for row in cur]


def _tidy(row: dict) -> dict:
    for k, v in row.items():
        if k in _RISK_COLUMNS and v is not None:
            row[k] = Risk(v).name if v > 0 or k != "level" else "NONE"
        elif isinstance(v, float) and math.isfinite(v):
            row[k] = round(v, 3)
    return row


def query(db: Path, what: str, run: int | None = None) -> list[dict]:
    """The rows of report ``what`` (``WHATS``) of ``db``, of one run or all; ``StoreError`` (one line) on bad input."""
    if what not in WHATS:
        raise StoreError(f"unknown report {what!r}: expected one of {', '.join(WHATS)}")
    conn = open_db(db, create=False)
    try:
        if run is not None and conn.execute("SELECT 1 FROM runs WHERE id = ?", (run,)).fetchone() is None:
            raise StoreError(f"{db}: no run {run} (see `lookahead query {db} summary`)")
        return fetch(conn, what, run)
    except sqlite3.Error as e:
        raise StoreError(f"{db}: cannot read ({e})") from None
    finally:
        conn.close()


def to_json(rows: list[dict]) -> str:
    """``rows`` as a JSON list of objects (NaN -> null, inf -> ``NEVER`` as in ``ticks.jsonl``)."""
    return json.dumps(jsonable(rows), ensure_ascii=False, indent=1) + "\n"


def to_csv(rows: list[dict]) -> str:
    """``rows`` as CSV with a header line (inf as ``inf``); empty for no rows."""
    buf = io.StringIO()
    if rows:
        w = csv.DictWriter(buf, fieldnames=list(rows[0]), lineterminator="\n")
        w.writeheader()
        w.writerows(rows)
    return buf.getvalue()
