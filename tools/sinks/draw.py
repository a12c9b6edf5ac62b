"""Drawing boxes and labels on RGB frames (OpenCV), for eyes."""

from __future__ import annotations

import cv2
import numpy as np

from lookahead.perception.detections import CLASSES

#: One colour per class (RGB).
CLASS_COLOURS = {
    "pedestrian": (255, 80, 80),
    "cyclist": (255, 170, 0),
    "motorcyclist": (255, 230, 0),
    "tricycle": (180, 120, 255),
    "car": (0, 200, 255),
    "truck": (0, 120, 255),
    "bus": (60, 60, 255),
    "animal": (0, 230, 120),
    "obstacle": (200, 200, 200),
}


def draw_box(img: np.ndarray, xyxy: np.ndarray, colour: tuple[int, int, int], text: str = "", thickness: int = 2) -> None:
    """Draw one xyxy box (float px) with a filled caption, in place."""
    if not np.all(np.isfinite(xyxy)):
        return
    h, w = img.shape[:2]
    x0, y0, x1, y1 = np.clip(np.round(xyxy), -10 * w, 10 * w).astype(int)
    cv2.rectangle(img, (x0, y0), (x1 - 1, y1 - 1), colour, thickness, cv2.LINE_AA)
    if text:
        (tw, th), base = cv2.getTextSize(text, cv2.FONT_HERSHEY_SIMPLEX, 0.4, 1)
        ty = y0 - 2 if y0 - th - 4 >= 0 else min(y1 + th + 2, h - 2)
        cv2.rectangle(img, (x0, ty - th - 2), (x0 + tw + 2, ty + base - 1), colour, -1)
        cv2.putText(img, text, (x0 + 1, ty - 1), cv2.FONT_HERSHEY_SIMPLEX, 0.4, (0, 0, 0), 1, cv2.LINE_AA)


def draw_ground_truth(img: np.ndarray, gt, amodal: bool = False) -> np.ndarray:
    """A copy of ``img`` with each visible actor's box, id, class and range drawn."""
    out = img.copy()
    for i in range(len(gt)):
        box = gt.amodal[i] if amodal else gt.visible[i]
        if not np.all(np.isfinite(box)) or gt.visible_fraction[i] <= 0:
            continue
        colour = CLASS_COLOURS.get(gt.cls[i], (255, 255, 255))
        draw_box(out, box, colour, f"{gt.name[i]} {gt.cls[i]} {gt.range[i]:.0f}m")
    return out


def draw_detections(img: np.ndarray, dets) -> np.ndarray:
    out = img.copy()
    for b, s, c in zip(dets.xyxy, dets.score, dets.class_id, strict=True):
        name = CLASSES[c] if 0 <= c < len(CLASSES) else str(c)
        draw_box(out, b, CLASS_COLOURS.get(name, (255, 255, 255)), f"{name} {s:.2f}", 1)
    return out


def save_rgb(path, img: np.ndarray) -> None:
    """Write an RGB image (converting to BGR at the OpenCV edge)."""
    if not cv2.imwrite(str(path), cv2.cvtColor(img, cv2.COLOR_RGB2BGR)):
        raise OSError(f"{path}: could not write image")
