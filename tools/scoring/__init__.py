"""Scoring a run directory against its ground truth (entry point: ``tools.scoring.run``).

Modules, one job each: ``io`` (read ``ticks.jsonl``, merge ``metrics.json``),
``matching`` (IoU matching primitives), ``detection``, ``tracking``,
``estimation`` (one ``metrics.json`` section each).
"""
