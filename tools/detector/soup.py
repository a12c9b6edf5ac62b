"""Weight averaging of ``CenterDet`` checkpoints (a "model soup", Wortsman et al., ICML 2022).

Checkpoints fine-tuned one from another (stage N+1 started from stage N) lie in one basin
of the loss, so the weighted mean of their parameters is itself a good network, and often
better than either: it keeps what the earlier stage knew and what the later one learned
(WiSE-FT, Wortsman et al., CVPR 2022, averages a fine-tuned model with its start the same
way). Every floating-point tensor of the state dicts is averaged -- weights, biases and
BatchNorm running statistics alike; integer counters are taken from the last checkpoint.
Checkpoints of different architectures cannot be averaged (``ArchitectureError``).

``lookahead soup-detector A.pt B.pt --weights 0.65,0.35 --out SOUP.onnx`` writes the ONNX
model (and ``SOUP.pt`` beside it, to fine-tune or average further).
"""

from __future__ import annotations

import json
import math
from collections.abc import Sequence
from pathlib import Path

import torch

from lookahead.tools.detector.arch import ArchitectureError
from lookahead.tools.detector.growth import architecture
from lookahead.tools.detector.model import CenterDet
from lookahead.tools.detector.train import export_onnx, model_metadata


def soup_weights(n: int, weights: Sequence[float] | None) -> list[float]:
    """``weights`` normalised to sum 1 (equal when None); one per checkpoint, none negative."""
    if weights is None:
        return [1.0 / n] * n
    w = [float(v) for v in weights]
    if len(w) != n:
        raise ValueError(f"one weight per checkpoint expected, got {len(w)} for {n}")
    if any(not math.isfinite(v) or v < 0 for v in w) or sum(w) <= 0:
        raise ValueError(f"non-negative weights with a positive sum expected, got {w}")
    total = sum(w)
    return [v / total for v in w]


def average_checkpoints(paths: Sequence[Path], weights: Sequence[float] | None = None) -> dict:
    """The weighted mean (``soup_weights``) of the state dicts saved at ``paths``."""
    if not paths:
        raise ValueError("no checkpoint to average")
    w = soup_weights(len(paths), weights)
    states, arch = [], None
    for p in paths:
        if not Path(p).is_file():
            raise FileNotFoundError(f"{p}: no such checkpoint")
        try:
            state = torch.load(p, map_location="cpu", weights_only=True)
        except Exception as e:  # noqa: BLE001 -- any unreadable file is the same user mistake
            raise ArchitectureError(f"{p}: not a checkpoint ({type(e).__name__})") from None
        try:
            if not isinstance(state, dict):
                raise ArchitectureError("not a state dict")
            a = architecture({k: tuple(v.shape) for k, v in state.items()})
        except ArchitectureError as e:
            raise ArchitectureError(f"{p}: {e}") from None
        if arch is not None and a != arch:
            raise ArchitectureError(f"{p}: architecture {a} differs from {paths[0]}'s {arch}; cannot average")
        arch = a
        states.append(state)
    return {k: sum(s[k].double() * wi for s, wi in zip(states, w, strict=True)).to(v.dtype)
            if v.is_floating_point() else v.clone() for k, v in states[-1].items()}


def soup(paths: Sequence[Path], out: Path, weights: Sequence[float] | None = None) -> Path:
    """Average the checkpoints at ``paths`` and export the network to ``out`` (ONNX; its
    checkpoint ``out`` with suffix ``.pt`` beside it). Returns ``out``."""
    w = soup_weights(len(paths), weights)
    state = average_checkpoints(paths, w)
    net = CenterDet(**architecture({k: tuple(v.shape) for k, v in state.items()}))
    net.load_state_dict(state)
    out = Path(out)
    out.parent.mkdir(parents=True, exist_ok=True)
    torch.save(net.state_dict(), out.with_suffix(".pt"))
    recipe = [{"checkpoint": str(p), "weight": round(wi, 6)} for p, wi in zip(paths, w, strict=True)]
    return export_onnx(net, out, model_metadata(None, None, {"soup": json.dumps(recipe)}))
