"""The YAML inputs of suites and replay configs, read and checked before anything heavy loads.

Light on purpose: the CLI reads a suite file or a replay config with these before the simulator
(highway-env, PyBullet, matplotlib) is imported, so a hostile file is refused at the cost of
Python's start-up alone (issue 31).
"""

from __future__ import annotations

from pathlib import Path

from lookahead.perception.safe_yaml import YamlError, first_non_finite, load_yaml, read_yaml_text
from lookahead.sim.scenario import ScenarioError, field_path
from lookahead.tools.sinks.paths import safe_file_stem

MAX_SUITE_SCENARIOS = 10_000
SUITE_KEYS = ("name", "description", "scenarios")


def read_yaml(path: str | Path, what: str = "suite") -> object:
    """Parsed YAML of ``path``, with the limits of ``perception.safe_yaml``; one-line
    ``ScenarioError`` for a missing, oversized or malformed file."""
    try:
        return load_yaml(read_yaml_text(path, what), str(path))[0]
    except YamlError as e:
        raise ScenarioError(str(e)) from None


def is_suite(data: object) -> bool:
    return isinstance(data, dict) and "scenarios" in data


def load_suite(path: str | Path) -> tuple[str, list[Path]]:
    """(name, scenario paths) of a suite YAML; one-line ``ScenarioError`` when it is wrong."""
    p = Path(path)
    data = read_yaml(p)
    if not isinstance(data, dict) or not isinstance(data.get("scenarios"), list) or not data["scenarios"]:
        raise ScenarioError(f"{p}: scenarios: expected a non-empty list of scenario paths")
    unknown = sorted(str(k) for k in data if k not in SUITE_KEYS)
    if unknown:
        raise ScenarioError(f"{p}: {unknown[0]}: unknown field (a suite has {', '.join(SUITE_KEYS)})")
    if not isinstance(data.get("name", ""), str) or not isinstance(data.get("description", ""), str):
        raise ScenarioError(f"{p}: name and description must be text")
    entries = data["scenarios"]
    bad = next((i for i, s in enumerate(entries) if not isinstance(s, str) or not s), None)
    if bad is not None:
        raise ScenarioError(f"{p}: scenarios[{bad}]: expected a scenario path, got {entries[bad]!r:.60}")
    if len(entries) > MAX_SUITE_SCENARIOS:
        raise ScenarioError(f"{p}: scenarios: {len(entries)} entries, more than the {MAX_SUITE_SCENARIOS} allowed")
    paths = [(p.parent / s).resolve() for s in entries]
    stems = [safe_file_stem(s.stem).lower() for s in paths]  # each run's directory (case-insensitive file systems)
    twice = next((i for i, s in enumerate(stems) if stems.index(s) != i), None)
    if twice is not None:
        raise ScenarioError(f"{p}: scenarios[{twice}]: {entries[twice]} would share its run directory with "
                            f"{entries[stems.index(stems[twice])]}; give the files distinct names")
    missing = [s for s in paths if not s.is_file()]
    if missing:
        raise ScenarioError(f"{p}: scenarios: no such scenario file {missing[0]}")
    return str(data.get("name", p.stem)), paths


#: The sections a replay config may override (``--config``).
OVERRIDE_SECTIONS = ("tracker", "estimator", "intent", "alerts")


class ReplayError(ValueError):
    """A replay that cannot run on its input (config, recorded run); one line naming the file
    (and line, for ``ticks.jsonl``) and the field."""


def read_overrides(config: str | Path) -> dict:
    """A replay config (``--config``): a YAML mapping of ``OVERRIDE_SECTIONS``, each a mapping.
    One-line ``ScenarioError`` (missing, too large, malformed YAML) or ``ReplayError`` (naming
    the file and the section) when it is not."""
    data = read_yaml(config, "replay config")
    if not isinstance(data, dict):
        raise ReplayError(f"{config}: expected a mapping of {' / '.join(OVERRIDE_SECTIONS)} overrides, "
                          f"got {type(data).__name__}")
    unknown = [str(k) for k in data if k not in OVERRIDE_SECTIONS]
    if unknown:
        raise ReplayError(f"{config}: unknown section(s) {', '.join(sorted(unknown))}; "
                          f"expected {', '.join(OVERRIDE_SECTIONS)}")
    for key, value in data.items():
        if not isinstance(value, dict):
            raise ReplayError(f"{config}: {key}: expected a mapping of settings, got {type(value).__name__}")
    bad = first_non_finite(data)
    if bad is not None:
        raise ReplayError(f"{config}: {field_path(bad[0])}: expected a finite number, got {bad[1]!r}")
    return data
