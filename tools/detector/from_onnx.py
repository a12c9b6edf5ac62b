"""Start training from an exported ``lookahead-det.onnx``: its weights back into a ``CenterDet``.

The export folds every BatchNorm into the convolution before it (``W' = W * g / s``,
``b' = beta - mean * g / s``), so the ONNX file holds one weight and bias per convolution
and no normalisation statistics. ``load_exported`` maps the file's convolutions onto the
network's in execution order (shapes checked), then *unfolds* each BatchNorm so that the
network computes exactly the exported function in eval mode and very nearly the same in
train mode: with ``y = W' * x`` (no bias) measured on calibration batches to have
per-channel mean ``mu`` and variance ``var``, the BatchNorm gets running statistics
``(mu, var)``, scale ``sqrt(var + eps)`` and shift ``mu + b'``. Eval mode gives
``(y - mu) + mu + b' = y + b'``; train mode normalises by the batch's own statistics,
which on batches like the calibration ones are ``mu`` and ``var`` again. Fine-tuning
then starts where the shipped model is, not from a network whose normalisation was lost.
Needs torch (the ``train`` extra), like ``model`` and ``growth``.
"""

from __future__ import annotations

import logging
from collections.abc import Iterable
from pathlib import Path

import onnx
import torch
from onnx import numpy_helper
from torch import nn

from lookahead.perception.detectors.onnx_detector import ModelError
from lookahead.tools.detector.arch import STAGES, ArchitectureError
from lookahead.tools.detector.growth import architecture
from lookahead.tools.detector.model import CenterDet

log = logging.getLogger(__name__)


class ExportedModelError(ModelError):
    """The ONNX file is not an export of this ``CenterDet`` architecture."""


def _onnx_convs(path: Path) -> list[tuple]:
    """(weight, bias or None, stride) of every Conv node of the graph, in graph (execution) order."""
    try:
        model = onnx.load(str(path))
    except Exception as e:  # protobuf decode errors, missing file
        raise ExportedModelError(f"{path}: cannot read the ONNX model ({e})") from None
    init = {t.name: numpy_helper.to_array(t) for t in model.graph.initializer}
    for node in model.graph.node:  # the exporter shares equal constants through Identity nodes
        if node.op_type == "Identity" and node.input[0] in init:
            init[node.output[0]] = init[node.input[0]]
    convs = []
    for node in model.graph.node:
        if node.op_type != "Conv":
            continue
        names = list(node.input[1:3])
        if names[0] not in init or (len(names) > 1 and names[1] not in init):
            raise ExportedModelError(f"{path}: Conv node {node.name!r} has weights that are not constants")
        strides = [int(a.ints[0]) for a in node.attribute if a.name == "strides"]
        convs.append((init[names[0]], init[names[1]] if len(names) > 1 else None, strides[0] if strides else 1))
    return convs


def _convs_in_call_order(net) -> list:
    """The network's Conv2d modules in the order a forward pass calls them."""
    order: list = []
    hooks = [m.register_forward_hook(lambda mod, _i, _o: order.append(mod))
             for m in net.modules() if isinstance(m, nn.Conv2d)]
    was_training = net.training
    net.eval()
    try:
        with torch.no_grad():
            net(torch.zeros(1, 3, 64, 64))
    finally:
        for h in hooks:
            h.remove()
        net.train(was_training)
    seen: dict[int, object] = {}
    for m in order:
        seen.setdefault(id(m), m)
    return list(seen.values())


def _exported_blocks(path: Path, convs: list[tuple]) -> tuple[int, ...]:
    """The residual blocks added to each stage (``arch.BLOCKS``) of an exported network, from where
    its stages start (the stride-2 convolutions of strides 2..32, in execution order) and where the
    backbone ends (the neck's first 1 x 1 convolution), against a ``CenterDet`` with none added
    (each added block is two convolutions)."""
    starts = [i for i, (_, _, stride) in enumerate(convs) if stride == 2]
    end = next((i for i, (w, _, _) in enumerate(convs) if starts and i > starts[-1] and w.shape[-1] == 1), None)
    if len(starts) != 5 or end is None:
        raise ExportedModelError(f"{path}: not a CenterDet: {len(starts)} stride-2 convolutions, 5 expected")
    bounds = [*starts[1:], end]
    lengths = [b - a for a, b in zip(bounds, bounds[1:], strict=False)]
    plain = CenterDet(widths=(1, 1, 1, 1, 1), neck=1, head=1)
    base = [sum(isinstance(m, nn.Conv2d) for m in getattr(plain, s).modules()) for s in STAGES]
    added = [n - b for n, b in zip(lengths, base, strict=True)]
    if any(x < 0 or x % 2 for x in added):
        raise ExportedModelError(f"{path}: not a CenterDet: stages of {lengths} convolutions")
    return tuple(x // 2 for x in added)


def exported_architecture(path: str | Path) -> dict:
    """``CenterDet`` keyword arguments (widths, neck, head, blocks) of the network exported to ``path``.

    The blocks come from where its stages start and end (``_exported_blocks``); then the
    file's convolutions, in execution order, are named after the modules a ``CenterDet``
    with those blocks calls in that order (the order does not depend on the widths).
    """
    path = Path(path)
    exported = _onnx_convs(path)
    ref = CenterDet(blocks=_exported_blocks(path, exported))
    names = {id(m): n for n, m in ref.named_modules()}
    order = [names[id(m)] for m in _convs_in_call_order(ref)]
    if len(exported) != len(order):
        raise ExportedModelError(f"{path}: {len(exported)} convolutions, a CenterDet has {len(order)}")
    shapes = {f"{n}.weight": tuple(w.shape) for n, (w, _, _) in zip(order, exported, strict=True)}
    try:
        return architecture(shapes)
    except ArchitectureError as e:
        raise ExportedModelError(f"{path}: {e}") from None


def _batchnorm_after(net) -> dict[int, object]:
    """id(conv) -> the BatchNorm2d that follows it in a ``model.conv`` block."""
    out = {}
    for m in net.modules():
        if isinstance(m, nn.Sequential):
            kids = list(m)
            for a, b in zip(kids, kids[1:], strict=False):
                if isinstance(a, nn.Conv2d) and isinstance(b, nn.BatchNorm2d):
                    out[id(a)] = b
    return out


def load_exported(net, path: str | Path, batches: Iterable) -> None:
    """Load the exported ONNX file ``path`` into ``net`` (a ``CenterDet``) in place.

    ``batches``: float tensors (B, 3, H, W) RGB in [0, 1] like the training crops, used
    to measure the convolution outputs' statistics (a few hundred crops are plenty).
    Raises ``ExportedModelError`` when the file's convolutions do not fit the network.
    """
    path = Path(path)
    exported = _onnx_convs(path)
    convs = _convs_in_call_order(net)
    if len(exported) != len(convs):
        raise ExportedModelError(f"{path}: {len(exported)} convolutions, the network has {len(convs)}")
    bns = _batchnorm_after(net)
    with torch.no_grad():
        for i, (conv, (w, b, _)) in enumerate(zip(convs, exported, strict=True)):
            if tuple(w.shape) != tuple(conv.weight.shape):
                raise ExportedModelError(
                    f"{path}: convolution {i} has weights {tuple(w.shape)}, the network {tuple(conv.weight.shape)}"
                )
            conv.weight.copy_(torch.from_numpy(w.copy()))
            bias = torch.zeros(w.shape[0]) if b is None else torch.from_numpy(b.copy()).float()
            bn = bns.get(id(conv))
            if bn is None:
                if conv.bias is None:
                    raise ExportedModelError(f"{path}: convolution {i} has a bias the network cannot hold")
                conv.bias.copy_(bias)
                continue
            bn.weight.fill_(1.0)
            bn.bias.copy_(bias)
            bn.running_mean.zero_()
            bn.running_var.fill_(1.0 - bn.eps)  # identity in eval mode: the exported function exactly
    _calibrate(net, bns, convs, batches)
    log.info("%s: %d convolutions loaded, BatchNorm unfolded", path, len(convs))


def _calibrate(net, bns: dict[int, object], convs: list, batches: Iterable) -> None:
    """Give each BatchNorm its input's measured statistics, keeping the eval-mode function."""
    sums: dict[int, list] = {}

    def record(mod, inputs, _out):
        y = inputs[0].detach().double()
        s = sums.setdefault(id(mod), [0.0, 0.0, 0])
        s[0] = s[0] + y.sum(dim=(0, 2, 3))
        s[1] = s[1] + (y * y).sum(dim=(0, 2, 3))
        s[2] += y.numel() // y.shape[1]

    targets = [bns[id(c)] for c in convs if id(c) in bns]
    hooks = [bn.register_forward_hook(record) for bn in targets]
    was_training = net.training
    net.eval()
    n = 0
    try:
        with torch.no_grad():
            for x in batches:
                net(x)
                n += 1
    finally:
        for h in hooks:
            h.remove()
        net.train(was_training)
    if n == 0:
        raise ExportedModelError("no calibration batches to unfold BatchNorm with")
    with torch.no_grad():
        for bn in targets:
            s0, s1, count = sums[id(bn)]
            mu = s0 / count
            var = (s1 / count - mu * mu).clamp(min=1e-6)
            bn.running_mean.copy_(mu.float())
            bn.running_var.copy_(var.float())
            bn.weight.copy_(torch.sqrt(var + bn.eps).float())
            bn.bias.add_(mu.float())
