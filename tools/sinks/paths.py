"""Output names and places: file stems made from names, and paths kept inside an output root.

Light on purpose (standard library only): the CLI checks its input with these before the
simulator is imported.
"""

from __future__ import annotations

import hashlib
import re
from pathlib import Path


class OutputError(RuntimeError):
    """An output path that cannot be written; ``str()`` is one line."""


#: Longest file stem made from a name (``safe_file_stem``), before the frame suffix.
MAX_STEM = 96
_UNSAFE = re.compile(r"[^A-Za-z0-9._-]")


def safe_file_stem(name: object, max_len: int = MAX_STEM) -> str:
    """``name`` as a file or directory name of one path component: characters other than
    ``[A-Za-z0-9._-]`` replaced by ``_``, leading dots dropped (no ``..``, no hidden file),
    at most ``max_len`` characters. A name that is already such a stem is returned as it is;
    any other gets ``-`` and 8 hex digits of a hash of the original appended, so two distinct
    names give two distinct stems (``base[v=1]`` -> ``base_v_1_-<hash>``)."""
    text = str(name)
    stem = _UNSAFE.sub("_", text).lstrip(".")
    if stem == text and 0 < len(stem) <= max_len:
        return stem
    digest = hashlib.sha256(text.encode("utf-8", "surrogatepass")).hexdigest()[:8]
    return f"{stem[: max(1, max_len - 9)]}-{digest}" if stem else f"_-{digest}"


def inside(root: Path, path: Path) -> Path:
    """``path``, checked to resolve to a place inside ``root`` (``OutputError`` otherwise): no
    output of an export lands outside ``--out`` whatever the names in its input."""
    base, target = Path(root).resolve(), Path(path).resolve()
    if target != base and base not in target.parents:
        raise OutputError(f"{path}: outside the output directory {root}; refusing to write there")
    return path
