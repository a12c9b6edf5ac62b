"""The report's behaviour / risk / CIPV section: confusion tables, and malformed input tolerated."""

from __future__ import annotations

from lookahead.tools.reports.html import confusion_table
from lookahead.tools.reports.report import _cards, behaviour_html, check_metrics

METRICS = {
    "behaviour": {
        "accuracy": 0.8, "macro_f1": 0.75,
        "worst": [{"group": "pedestrian", "behaviour": "walking", "f1": 0.5, "support": 4}],
        "per_group": {"pedestrian": {"accuracy": 0.8, "macro_f1": 0.75, "confusion": {
            "labels": ["standing", "walking"], "matrix": [[3, 0], [2, 2]]}}},
        "risk": {"accuracy": 0.9, "confusion": {"labels": ["SAFE", "HIGH"], "matrix": [[5, 0], [1, 4]]}},
    },
    "cipv": {"correct_rate": 0.97, "frames": 100, "switches": 1},
}


def test_behaviour_section_shows_matrices_cards_and_cipv(tmp_path):
    check_metrics(tmp_path / "metrics.json", METRICS)
    page = behaviour_html(METRICS)
    assert "pedestrian: accuracy 0.8" in page and "risk level: accuracy 0.9" in page
    assert page.count("<table>") == 4  # two confusions, the worst behaviours, the CIPV counts
    assert "<th class=\"l\">walking</th>" in page and "correct_rate" in page
    cards = _cards(METRICS)
    assert "behaviour macro F1" in cards and "CIPV correct target" in cards and "risk-level accuracy" in cards
    assert behaviour_html({"intent": {}}) == ""  # metrics scored before these sections: nothing


def test_malformed_confusions_are_left_out():
    assert confusion_table(None) == "" and confusion_table({"labels": ["a"], "matrix": [[1, 2]]}) == ""
    assert confusion_table({"labels": ["a"], "matrix": [["x"]]}) == ""
    page = behaviour_html({"behaviour": {"per_group": {"pedestrian": {"confusion": "bad"}}, "risk": [], "worst": 3}})
    assert "<h2>" in page
