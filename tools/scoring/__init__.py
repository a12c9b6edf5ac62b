"""Scoring a run directory against its ground truth (entry point: ``tools.scoring.run``).

Modules, one job each: ``io`` (the typed frames of ``ticks.jsonl``, built from
``tools.sinks.rundir.RunDir``, the one reader of run directories), ``matching``
(IoU matching primitives), ``detection``, ``tracking``, ``estimation``, ``intent``,
``timing`` (``metrics.json`` sections), ``totals`` (suite and sweep totals).
"""
