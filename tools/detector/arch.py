"""``CenterDet``'s architecture: its default widths, reading them back from weights, growing.

``WIDTHS``, ``NECK``, ``HEAD``, ``BLOCKS``: the channels and added residual blocks of the
shipped model's network, the defaults of ``CenterDet`` and of ``lookahead train-detector``.

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

``architecture(shapes)`` reads a network's widths and blocks back from its weights' shapes,
so ``--init`` can take a checkpoint or an exported model of any size.
"""

from __future__ import annotations

from collections.abc import Iterable, Mapping
from typing import TYPE_CHECKING

if TYPE_CHECKING:  # torch is the extra `train`; this module imports without it (constants, error class)
    from lookahead.tools.detector.model import CenterDet


WIDTHS: tuple[int, int, int, int, int] = (24, 32, 64, 96, 128)  # backbone, strides 2, 4, 8, 16, 32
NECK = 64  # strides 8, 16
HEAD = 32  # stride 4
BLOCKS: tuple[int, int, int, int] = (0, 0, 0, 0)  # residual blocks added to the stages at strides 4, 8, 16, 32
STAGES = ("s4", "s8", "s16", "s32")
BASE_LAYERS = 2  # layers of each of those stages before the added blocks


class ArchitectureError(ValueError):
    """Weights that are not a ``CenterDet``, or do not fit into the network asked for."""


#: parameter -> what its first dimension is (``CenterDet``'s constructor arguments)
_WIDTH_OF = {
    "s2.0.weight": "w2", "s4.0.0.weight": "w4", "s8.0.0.weight": "w8", "s16.0.0.weight": "w16",
    "s32.0.0.weight": "w32", "l32.0.weight": "neck", "l4.0.weight": "head",
}


def added_blocks(names: Iterable[str]) -> tuple[int, ...]:
    """The residual blocks added to each stage (``BLOCKS``' layout) of a network with these parameters."""
    last = dict.fromkeys(STAGES, BASE_LAYERS - 1)
    for name in names:
        stage, _, rest = name.partition(".")
        index = rest.partition(".")[0]
        if stage in last and index.isdigit():
            last[stage] = max(last[stage], int(index))
    return tuple(last[s] - (BASE_LAYERS - 1) for s in STAGES)


def architecture(shapes: Mapping[str, tuple[int, ...]]) -> dict:
    """``CenterDet`` keyword arguments (``widths``, ``neck``, ``head``, ``blocks``) from parameter shapes.

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
    from lookahead.tools.detector.model import CenterDet

    ref = CenterDet(**arch).state_dict()
    for k, shape in shapes.items():
        want = tuple(ref[k].shape) if k in ref else None
        if tuple(shape) != want:
            raise ArchitectureError(f"not a CenterDet with {arch}: {k} is {tuple(shape)}, expected {want}")
    return arch


def grow(src: CenterDet, dst: CenterDet) -> CenterDet:
    """Copy ``src`` into the wider or deeper ``dst`` in place (module docstring); returns ``dst``."""
    import torch

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
