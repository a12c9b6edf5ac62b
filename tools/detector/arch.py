"""``CenterDet``'s architecture: its default widths and added blocks (no torch needed).

``WIDTHS``, ``NECK``, ``HEAD``, ``BLOCKS``: the channels and added residual blocks of the
shipped model's network, the defaults of ``CenterDet`` and of ``lookahead train-detector``.

``added_blocks(names)`` reads the added blocks back from parameter names; reading a whole
architecture back and growing a network need torch (``tools.detector.growth``).
"""

from __future__ import annotations

from collections.abc import Iterable

WIDTHS: tuple[int, int, int, int, int] = (24, 32, 64, 96, 128)  # backbone, strides 2, 4, 8, 16, 32
NECK = 64  # strides 8, 16
HEAD = 32  # stride 4
BLOCKS: tuple[int, int, int, int] = (0, 0, 0, 0)  # residual blocks added to the stages at strides 4, 8, 16, 32
STAGES = ("s4", "s8", "s16", "s32")
BASE_LAYERS = 2  # layers of each of those stages before the added blocks


class ArchitectureError(ValueError):
    """Weights that are not a ``CenterDet``, or do not fit into the network asked for."""


def added_blocks(names: Iterable[str]) -> tuple[int, ...]:
    """The residual blocks added to each stage (``BLOCKS``' layout) of a network with these parameters."""
    last = dict.fromkeys(STAGES, BASE_LAYERS - 1)
    for name in names:
        stage, _, rest = name.partition(".")
        index = rest.partition(".")[0]
        if stage in last and index.isdigit():
            last[stage] = max(last[stage], int(index))
    return tuple(last[s] - (BASE_LAYERS - 1) for s in STAGES)
