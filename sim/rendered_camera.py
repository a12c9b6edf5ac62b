"""One camera drawn by a render worker, and ground truth's visibility measured on its frames.

``RenderedCamera`` bundles what a rendered camera of the loop needs: a ``RenderProcess``
(renderer and weather in a worker process), the actors alone (``Silhouettes``) and the flat
ground's depth per pixel, both for ``groundtruth.with_visibility``. ``submit`` asks the
worker for a frame seen from a pose; ``develop`` collects it and measures the ground truth's
visibility on it. The ego's camera (``sim.runner``) and every rendered sender's
(``sim.cooperation``) are one each.
"""

from __future__ import annotations

import time
from collections.abc import Mapping
from typing import Any

import numpy as np

from lookahead.perception.camera import CameraModel
from lookahead.sim.groundtruth import GroundTruth, with_visibility
from lookahead.sim.layout import RoadLayout
from lookahead.sim.render_process import RenderProcess
from lookahead.sim.shapes import ActorShape
from lookahead.sim.silhouettes import Silhouettes

Poses = Mapping[int, tuple[float, float, float, float]]  # actor id -> world (x, y, heading, gait phase)


class RenderedCamera:
    """``camera`` drawn by a render worker over ``layout`` with the actors ``shapes``.

    Args:
        backend: "egl", "tiny" or "auto" (``RenderProcess``); scenario: its weather is applied;
        gl_threads: the worker's llvmpipe threads (None: the driver's default).
    """

    def __init__(self, camera: CameraModel, layout: RoadLayout, seed: int, backend: str,
                 shapes: Mapping[int, ActorShape], scenario: Any = None, gl_threads: int | None = None) -> None:
        self.camera = camera
        self.process = RenderProcess(camera, layout, seed, backend, shapes, scenario, gl_threads=gl_threads)
        try:
            self.silhouettes = Silhouettes(camera, layout, seed, far=self.process.far)
            for actor_id, shape in shapes.items():
                self.silhouettes.add_actor(actor_id, shape)
        except BaseException:
            self.process.close()
            raise
        self.ground_depth = camera.ground_depth().astype(np.float32)

    @property
    def backend(self) -> str:
        return self.process.backend

    def submit(self, frame_index: int, pose: tuple[float, float, float], poses: Poses) -> None:
        """Ask for the frame seen from world ``pose`` (x, y, heading of the camera's frame
        origin) with the actors at ``poses`` (others hidden)."""
        self.process.submit(frame_index, pose, poses)

    def develop(self, gt: GroundTruth, pose: tuple[float, float, float],
                poses: Poses) -> tuple[np.ndarray, np.ndarray, np.ndarray, GroundTruth, float, float]:
        """The oldest frame asked for: (image with weather, depth, segmentation, ``gt`` with its
        visibility measured on them, the worker's ms, the visibility's ms); ``pose`` and
        ``poses`` as submitted."""
        image, depth, seg, worker_ms = self.process.result()
        t0 = time.perf_counter()
        silhouettes = self.silhouettes

        def alone(ids: list[int], window: tuple[int, int, int, int]) -> np.ndarray:
            return silhouettes(pose, poses, ids, window)

        gt = with_visibility(gt, self.camera, seg, depth, alone, self.ground_depth)
        return image, depth, seg, gt, worker_ms, (time.perf_counter() - t0) * 1e3

    def close(self) -> None:
        self.process.close()
        self.silhouettes.close()
