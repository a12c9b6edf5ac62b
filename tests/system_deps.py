"""What the tests need from the machine beyond the venv (``setup/system.sh`` provides it).

A test that needs a Debian package or OpenCV's sample clip asks here: it skips with the reason
when the thing is missing, or fails under ``LOOKAHEAD_REQUIRE_SYSTEM=1`` (``make test`` sets it
after running ``setup/system.sh``), so CI never skips one silently.
"""

from __future__ import annotations

import os
import shutil
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
VTEST_AVI = ROOT / ".cache" / "opencv-doc" / "vtest.avi"  # OpenCV's sample clip (Debian opencv-doc)


def _missing(what: str) -> None:
    message = f"{what} (run setup/system.sh as root)"
    if os.environ.get("LOOKAHEAD_REQUIRE_SYSTEM") == "1":
        pytest.fail(f"missing on this machine: {message}")
    pytest.skip(f"missing: {message}")


def require_file(path: Path, what: str) -> Path:
    """``path`` if it exists and is not empty, else skip (or fail under make test)."""
    if not (path.is_file() and path.stat().st_size > 0):
        _missing(f"{what} at {path}")
    return path


def require_command(name: str) -> str:
    """The full path of the program ``name``, else skip (or fail under make test)."""
    found = shutil.which(name)
    if found is None:
        _missing(f"program {name}")
    return found  # type: ignore[return-value]


def vtest_avi() -> Path:
    """OpenCV's sample clip vtest.avi (768x576, 795 frames of pedestrians)."""
    return require_file(VTEST_AVI, "OpenCV's sample clip vtest.avi")


#: Debian's Python (with the Debian packages' modules, e.g. python3-gi), not the venv's.
SYSTEM_PYTHON = "/usr/bin/python3"


def require_system_python(args: list[str], what: str, timeout: float = 30.0) -> str:
    """``SYSTEM_PYTHON`` if ``SYSTEM_PYTHON *args`` exits 0 (e.g. a script's self-check that the
    Debian packages it imports are installed), else skip (or fail under make test) naming ``what``
    and what the check said."""
    import subprocess

    if not Path(SYSTEM_PYTHON).is_file():
        _missing(f"{what}: no {SYSTEM_PYTHON}")
    try:
        done = subprocess.run([SYSTEM_PYTHON, *args], capture_output=True, text=True, timeout=timeout)
    except (OSError, subprocess.TimeoutExpired) as exc:
        _missing(f"{what}: {exc}")
    else:
        if done.returncode != 0:
            said = " ".join((done.stderr or done.stdout).strip().splitlines()[-1:])
            _missing(f"{what}: {said}" if said else what)
    return SYSTEM_PYTHON


def require_cjk_font() -> tuple[str, int]:
    """(file, face index) of an installed font with Chinese glyphs (Debian fonts-wqy-microhei),
    else skip (or fail under make test)."""
    from lookahead.tools.sinks.video import find_cjk_font

    found = find_cjk_font()
    if found is None:
        _missing("a font with Chinese glyphs (Debian fonts-wqy-microhei)")
    return found  # type: ignore[return-value]
