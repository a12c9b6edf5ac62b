"""Suite files: a name and a list of scenario paths (relative to the suite file)."""

from __future__ import annotations

from pathlib import Path

import yaml

from sim.scenario import ScenarioError


def load_suite(path: str | Path) -> tuple[str, list[Path]]:
    """(name, scenario paths) of a suite YAML; one-line ``ScenarioError`` when it is wrong."""
    p = Path(path)
    if not p.is_file():
        raise ScenarioError(f"{p}: no such suite file")
    try:
        data = yaml.safe_load(p.read_text(encoding="utf-8"))
    except yaml.YAMLError as e:
        raise ScenarioError(f"{p}: malformed YAML: {getattr(e, 'problem', e)}") from None
    if not isinstance(data, dict) or not isinstance(data.get("scenarios"), list) or not data["scenarios"]:
        raise ScenarioError(f"{p}: scenarios: expected a non-empty list of scenario paths")
    paths = [(p.parent / str(s)).resolve() for s in data["scenarios"]]
    missing = [s for s in paths if not s.is_file()]
    if missing:
        raise ScenarioError(f"{p}: scenarios: no such scenario file {missing[0]}")
    return str(data.get("name", p.stem)), paths
