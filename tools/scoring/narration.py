"""The ``narration`` section: how the alerts' sentences were made and whether what they say is true.

Reads ``RUN_DIR/narration.jsonl`` (``tools.sinks.narration``). For every line and language the
facts the sentence states (``intent.narration.extract_facts``: class, side, range, TTC) are
checked (``intent.narration.check``: class and side equal, range within max(1 m, 15 %), TTC
within max(0.5 s, 25 %)) against the tick's assessment (``facts``) and against ground truth
(``truth_facts``; lines whose alert matched no ground-truth actor are counted as ``no_truth`` and
left out of it). Keys:

* ``alerts`` (lines), ``by_source`` ({template, llm}: count), ``fallback_reasons`` ({reason: count});
* ``agreement``: ``{"assessment" | "truth": {lang: {fact: rate}, "all": {fact: rate}}}`` -- rate =
  agreeing / checked sentences (a fact with nothing to check against -- side unknown -- is not
  counted), null when none was checked; ``all`` pools both languages; ``sentences_all_agree``: the
  share of sentences every checked fact of which agrees;
* ``checked``: the same layout with the numbers of sentences checked per fact;
* ``no_truth``: lines without ground truth;
* ``llm_latency_ms``: median and max of the answered requests' latency (``source`` llm), null
  without; ``latency_ms_max``: the largest latency of any request (answered or not).
"""

from __future__ import annotations

import json
import statistics
from pathlib import Path

from lookahead.intent.narration import FACTS_CHECKED, LANGS, Facts, check, extract_facts

NARRATION_FILE = "narration.jsonl"


def _rate(n: int, d: int) -> float | None:
    return round(n / d, 4) if d else None


def read_narration(path: Path) -> list[dict]:
    lines = []
    with Path(path).open(encoding="utf-8") as f:
        for n, text in enumerate(f, 1):
            if text.strip():
                try:
                    lines.append(json.loads(text))
                except json.JSONDecodeError as e:
                    raise ValueError(f"{path}:{n}: not JSON ({e.msg})") from None
    return lines


def narration_section(run_dir: Path | str) -> dict | None:
    """The ``narration`` section of a run directory's metrics (module docstring); None without
    ``narration.jsonl``."""
    path = Path(run_dir) / NARRATION_FILE
    if not path.is_file():
        return None
    lines = read_narration(path)
    by_source: dict[str, int] = {}
    reasons: dict[str, int] = {}
    agree = {ref: {k: dict.fromkeys(FACTS_CHECKED, 0) for k in (*LANGS, "all")} for ref in ("assessment", "truth")}
    checked = {ref: {k: dict.fromkeys(FACTS_CHECKED, 0) for k in (*LANGS, "all")} for ref in ("assessment", "truth")}
    whole = {ref: [0, 0] for ref in ("assessment", "truth")}
    no_truth = 0
    llm_latency: list[float] = []
    latencies: list[float] = []
    for line in lines:
        by_source[line["source"]] = by_source.get(line["source"], 0) + 1
        if line.get("fallback_reason"):
            reasons[line["fallback_reason"]] = reasons.get(line["fallback_reason"], 0) + 1
        if line.get("latency_ms") is not None:
            latencies.append(float(line["latency_ms"]))
            if line["source"] == "llm":
                llm_latency.append(float(line["latency_ms"]))
        refs = {"assessment": Facts.from_dict(line["facts"])}
        if line.get("truth_facts"):
            refs["truth"] = Facts.from_dict(line["truth_facts"])
        else:
            no_truth += 1
        for lang in LANGS:
            stated = extract_facts(line.get(lang) or "", lang)
            for ref, facts in refs.items():
                result = check(stated, facts)
                for fact, ok in result.items():
                    if ok is None:
                        continue
                    for k in (lang, "all"):
                        checked[ref][k][fact] += 1
                        agree[ref][k][fact] += int(ok)
                whole[ref][0] += int(all(v is not False for v in result.values()))
                whole[ref][1] += 1
    agreement = {ref: {k: {f: _rate(agree[ref][k][f], checked[ref][k][f]) for f in FACTS_CHECKED}
                       for k in (*LANGS, "all")} for ref in agree}
    for ref in agreement:
        agreement[ref]["sentences_all_agree"] = _rate(*whole[ref])
    return {
        "alerts": len(lines),
        "by_source": by_source,
        "fallback_reasons": reasons,
        "agreement": agreement,
        "checked": checked,
        "no_truth": no_truth,
        "llm_latency_ms": {"median": round(statistics.median(llm_latency), 2), "max": round(max(llm_latency), 2)}
        if llm_latency else None,
        "latency_ms_max": round(max(latencies), 2) if latencies else None,
    }
