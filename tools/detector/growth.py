"""Growing a trained ``CenterDet``, and reading its architecture back from weights (needs torch).

``grow(src, dst)`` grows a trained ``CenterDet`` into a wider and deeper one that computes
the same function. Deeper: the residual blocks ``dst`` adds at the end of a stage
(``blocks``) start as the identity (``model.CenterDet``), and keep their own initialisation.
Wider: it copies every parameter and BatchNorm statistic of ``src`` into the matching
leading block of ``dst`` (a ``CenterDet`` with at least as many channels everywhere). For
each convolution weight (out, in, k, k):

* rows of old outputs, columns of old inputs: ``src``'s weights;
* rows of old outputs, columns of new inputs: zero, so no old channel depends on a new one;
* rows of new outputs: ``dst``'s own fresh initialisation.

Old channels so compute exactly what they did (in train mode too: their BatchNorm
statistics see the same values), new channels compute something, and nothing reads them
yet -- the heads' columns for them are zero. The first gradient step reaches those
zero columns (their gradient is the new channels' activity times the loss gradient), so
fine-tuning starts at the trained model and grows into the new width (Net2Net's
function-preserving growth, with zero instead of split fan-out; its deeper growth with
zero-scaled residual blocks).

More classes: the heat head's rows of new classes are ``dst``'s fresh ones (bias at the
focal-loss prior), so a model of the eight road-user classes starts a nine-class one
(``obstacle`` added) that finds everything it found and nothing of the new class yet.

``architecture(shapes)`` reads a network's widths, blocks and class count back from its
weights' shapes, so ``--init`` can take a checkpoint or an exported model of any size.
"""

from __future__ import annotations

from collections.abc import Mapping

import torch

from lookahead.tools.detector.arch import ArchitectureError, added_blocks
from lookahead.tools.detector.model import CenterDet

#: parameter -> what its first dimension is (``CenterDet``'s constructor arguments)
_WIDTH_OF = {
    "s2.0.weight": "w2", "s4.0.0.weight": "w4", "s8.0.0.weight": "w8", "s16.0.0.weight": "w16",
    "s32.0.0.weight": "w32", "l32.0.weight": "neck", "l4.0.weight": "head",
}


def architecture(shapes: Mapping[str, tuple[int, ...]]) -> dict:
    """``CenterDet`` keyword arguments (``widths``, ``neck``, ``head``, ``blocks``, and ``num_classes`` when
    the heat head is among them) from parameter shapes.

    ``shapes``: parameter name -> shape, for a whole state dict or only some of it (an
    exported model's convolution weights); each must fit the architecture found, else
    ``ArchitectureError`` names the first that does not.
    """
    missing = [k for k in _WIDTH_OF if k not in shapes]
    if missing:
        raise ArchitectureError(f"not a CenterDet: no parameter {missing[0]!r}")
    w = {name: int(shapes[key][0]) for key, name in _WIDTH_OF.items()}
    arch = {"widths": (w["w2"], w["w4"], w["w8"], w["w16"], w["w32"]), "neck": w["neck"], "head": w["head"],
            "blocks": added_blocks(shapes)}
    if "heat.weight" in shapes:  # the class count: a model of fewer classes grows into more (``grow``)
        arch["num_classes"] = int(shapes["heat.weight"][0])
    ref = CenterDet(**arch).state_dict()
    for k, shape in shapes.items():
        want = tuple(ref[k].shape) if k in ref else None
        if tuple(shape) != want:
            raise ArchitectureError(f"not a CenterDet with {arch}: {k} is {tuple(shape)}, expected {want}")
    return arch


def grow(src: CenterDet, dst: CenterDet) -> CenterDet:
    """Copy ``src`` into the wider or deeper ``dst`` in place (module docstring); returns ``dst``."""
    with torch.no_grad():
        _copy_into(src, dst)
    return dst


def _copy_into(src: CenterDet, dst: CenterDet) -> None:
    old, new = src.state_dict(), dst.state_dict()
    if not old.keys() <= new.keys():
        raise ArchitectureError(f"{src.arch} does not fit into {dst.arch} ({next(iter(old.keys() - new.keys()))} "
                                "has nowhere to go); a network can be grown, not shrunk")
    for k, a in old.items():
        b = new[k]
        if a.ndim != b.ndim or any(x > y for x, y in zip(a.shape, b.shape, strict=True)):
            raise ArchitectureError(f"{src.arch} does not fit into {dst.arch} ({k}: {tuple(a.shape)} into "
                                    f"{tuple(b.shape)}); a network can be grown, not shrunk")
        if a.ndim == 0:  # BatchNorm's num_batches_tracked
            b.copy_(a)
            continue
        rows = slice(0, a.shape[0])
        if a.ndim >= 2:  # convolution weight (out, in, k, k)
            b[rows, a.shape[1]:] = 0.0
            b[rows, : a.shape[1]] = a
        else:  # bias, BatchNorm weight / bias / running statistics
            b[rows] = a
