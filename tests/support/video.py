"""Reading back the videos the tests write (OpenCV, BGR frames)."""

from __future__ import annotations

from collections.abc import Iterator
from pathlib import Path

import cv2
import numpy as np


def iter_frames(path: Path) -> Iterator[np.ndarray]:
    """Every frame OpenCV decodes from ``path``, in order (an assertion if it cannot open it)."""
    cap = cv2.VideoCapture(str(path))
    assert cap.isOpened(), f"OpenCV cannot open {path} ({Path(path).stat().st_size} bytes)"
    try:
        while True:
            ok, img = cap.read()
            if not ok:
                return
            yield img
    finally:
        cap.release()


def read_frames(path: Path) -> list[np.ndarray]:
    return list(iter_frames(path))


def count_frames(path: Path) -> int:
    return sum(1 for _ in iter_frames(path))
