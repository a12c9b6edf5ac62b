"""The packaged catalogue: the shipped detector and the scenario files, wherever lookahead is installed.

``models/`` and ``scenarios/`` travel as the data packages ``lookahead.models`` and
``lookahead.scenarios`` (see ``setup.py``), found with ``importlib.resources`` — in a
checkout (editable install) they are the repository's folders, in an installed wheel
the copies inside it. Wheels install unpacked, so both are plain directories.
The shipped detector, ``DEFAULT_MODEL``, is found the same way in ``perception.config``
(perception finds its model without sim).
"""

from __future__ import annotations

from importlib.resources import files
from pathlib import Path

#: The folder of the scenario catalogue (scenarios, ``suites/``, ``sweeps/``, ``generators/``, and
#: ``ncap/``: the Euro NCAP cases, docs/ncap.md).
SCENARIOS = Path(str(files("lookahead.scenarios")))
#: Sub-folders searched, in order, for a catalogue name.
KINDS = ("", "suites", "sweeps", "generators", "ncap")


def catalogue_names() -> list[str]:
    """Every packaged YAML file's name, as ``resolve_path`` accepts it."""
    out = []
    for kind in KINDS:
        folder = SCENARIOS / kind
        out += sorted(f"{kind}/{p.stem}".lstrip("/") for p in folder.glob("*.yaml"))
    return out


def resolve_path(arg: str | Path) -> Path:
    """``arg`` as given when that file exists, else the packaged file of that name.

    A bare name (no ``.yaml``, no folder) is looked up in the catalogue's top folder, then
    ``suites/``, ``sweeps/`` and ``generators/``; a name that is nowhere is returned as given,
    so the loader reports the missing file with the user's own spelling.
    """
    path = Path(arg)
    if path.exists() or path.is_absolute():
        return path
    for kind in KINDS:
        candidate = SCENARIOS / kind / (path.name if path.suffix == ".yaml" else f"{path}.yaml")
        if len(path.parts) == 1 and candidate.is_file():
            return candidate
    candidate = SCENARIOS / (path if path.suffix == ".yaml" else path.with_suffix(".yaml"))
    return candidate if candidate.is_file() else path
