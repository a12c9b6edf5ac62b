"""``CenterDet``: a compact single-stage, anchor-free detector (CenterNet-style) at stride 4.

Input: (B, 3, H, W) RGB in [0, 1], H and W multiples of 32 (the shipped model: 384 x 640,
the letterboxed 640 x 360 camera). A plain conv backbone (strides 2..32) and a
top-down neck produce stride-4 features; the head predicts per cell

* ``heat`` (C,): logit of "an object of class c has its box centre in this cell";
* ``reg`` (4,): the centre's offset from the cell (2, in cells, in (-0.5, 1.5):
  ``cell_offset``) and log(w / 4), log(h / 4).

``Decoded`` (the exported graph) turns these into the YOLOv8 output layout
``[B, 4 + C, N]`` (N = H/4 * W/4 cells; rows cx, cy, w, h in input pixels, then the
C class scores), with CenterNet's 3 x 3 max-pool peak test folded into the scores
(a cell that is not a local maximum of its class scores 0), so
``perception.detectors.onnx_detector.OnnxDetector`` runs it unchanged.
"""

from __future__ import annotations

import torch
from torch import nn
from torch.nn import functional as F

from lookahead.perception.detections import CLASSES
from lookahead.tools.detector.arch import BLOCKS, HEAD, NECK, WIDTHS

STRIDE = 4


def conv(c_in: int, c_out: int, stride: int = 1, k: int = 3) -> nn.Sequential:
    return nn.Sequential(
        nn.Conv2d(c_in, c_out, k, stride, k // 2, bias=False), nn.BatchNorm2d(c_out), nn.ReLU(inplace=True)
    )


class Residual(nn.Module):
    def __init__(self, c: int) -> None:
        super().__init__()
        self.a, self.b = conv(c, c), conv(c, c)

    def forward(self, x: torch.Tensor) -> torch.Tensor:
        return x + self.b(self.a(x))


class Basic(nn.Module):
    """ResNet's basic block, ``relu(x + bn(conv(conv(x))))``, on a non-negative input (a ReLU's).

    Its last BatchNorm's scale starts at zero, so the block starts as the identity (in
    train mode too) and the first gradient reaches that scale (no ReLU between it and the
    sum, unlike ``Residual``'s, whose zero output would pass no gradient back)."""

    def __init__(self, c: int) -> None:
        super().__init__()
        self.a = conv(c, c)
        self.b = nn.Sequential(nn.Conv2d(c, c, 3, 1, 1, bias=False), nn.BatchNorm2d(c))
        nn.init.zeros_(self.b[1].weight)

    def forward(self, x: torch.Tensor) -> torch.Tensor:
        return F.relu(x + self.b(self.a(x)))


def _added(c: int, n: int) -> list[Basic]:
    """``n`` blocks of ``c`` channels added at the end of a stage, each starting as the identity."""
    return [Basic(c) for _ in range(n)]


class CenterDet(nn.Module):
    """Backbone + neck + head (module docstring); ``widths`` = channels at strides 2, 4, 8, 16, 32;
    ``blocks`` = residual blocks added at the end of the stages at strides 4, 8, 16, 32.

    An added block (``Basic``) starts as the identity, so a network with more blocks can start
    from the weights of one with fewer and compute the same function (``arch.grow``).
    """

    def __init__(self, num_classes: int = len(CLASSES), widths: tuple[int, ...] = WIDTHS, neck: int = NECK,
                 head: int = HEAD, blocks: tuple[int, ...] = BLOCKS) -> None:
        super().__init__()
        w2, w4, w8, w16, w32 = widths
        self.num_classes = num_classes
        self.arch = {"widths": tuple(widths), "neck": neck, "head": head, "blocks": tuple(blocks),
                     "num_classes": num_classes}
        self.s2 = conv(3, w2, 2)
        self.s4 = nn.Sequential(conv(w2, w4, 2), conv(w4, w4), *_added(w4, blocks[0]))
        self.s8 = nn.Sequential(conv(w4, w8, 2), Residual(w8), *_added(w8, blocks[1]))
        self.s16 = nn.Sequential(conv(w8, w16, 2), Residual(w16), *_added(w16, blocks[2]))
        self.s32 = nn.Sequential(conv(w16, w32, 2), conv(w32, w32), *_added(w32, blocks[3]))
        self.l32, self.l16, self.l8 = conv(w32, neck, k=1), conv(w16, neck, k=1), conv(w8, neck, k=1)
        self.f16, self.f8 = conv(neck, neck), conv(neck, neck)
        self.l4, self.d8 = conv(w4, head, k=1), conv(neck, head, k=1)
        self.f4 = conv(head, head)
        self.heat = nn.Conv2d(head, num_classes, 1)
        self.reg = nn.Conv2d(head, 4, 1)
        nn.init.constant_(self.heat.bias, -4.6)  # prior 0.01 (focal-loss initialisation)
        nn.init.zeros_(self.reg.weight)
        nn.init.zeros_(self.reg.bias)

    def forward(self, x: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor]:
        """(heat logits (B, C, H/4, W/4), reg (B, 4, H/4, W/4))."""
        x4 = self.s4(self.s2(x))
        x8 = self.s8(x4)
        x16 = self.s16(x8)
        x32 = self.s32(x16)
        p16 = self.f16(self.l16(x16) + F.interpolate(self.l32(x32), scale_factor=2.0, mode="nearest"))
        p8 = self.f8(self.l8(x8) + F.interpolate(p16, scale_factor=2.0, mode="nearest"))
        p4 = self.f4(self.l4(x4) + F.interpolate(self.d8(p8), scale_factor=2.0, mode="nearest"))
        return self.heat(p4), self.reg(p4)


def cell_offset(raw: torch.Tensor) -> torch.Tensor:
    """Raw offset outputs -> the box centre's offset from its cell (cells), in (-0.5, 1.5)."""
    return torch.sigmoid(raw) * 2.0 - 0.5


def cell_size(raw: torch.Tensor) -> torch.Tensor:
    """Raw log-size outputs -> box width, height in cells (clamped to e^-4 .. e^6)."""
    return torch.exp(raw.clamp(-4.0, 6.0))


def decode_boxes(reg: torch.Tensor) -> torch.Tensor:
    """(B, 4, h, w) raw regression -> (B, 4, h, w) boxes cx, cy, w, h in input pixels."""
    _, _, h, w = reg.shape
    ys = torch.arange(h, dtype=reg.dtype, device=reg.device).view(1, h, 1)
    xs = torch.arange(w, dtype=reg.dtype, device=reg.device).view(1, 1, w)
    off = cell_offset(reg[:, 0:2])
    cx = (xs + off[:, 0]) * STRIDE
    cy = (ys + off[:, 1]) * STRIDE
    size = cell_size(reg[:, 2:4]) * STRIDE
    return torch.stack([cx, cy, size[:, 0], size[:, 1]], dim=1)


class Decoded(nn.Module):
    """The exported graph: ``CenterDet`` + sigmoid, 3 x 3 peak test and box decoding -> [B, 4 + C, N]."""

    def __init__(self, net: CenterDet) -> None:
        super().__init__()
        self.net = net

    def forward(self, x: torch.Tensor) -> torch.Tensor:
        heat, reg = self.net(x)
        score = torch.sigmoid(heat)
        peak = F.max_pool2d(score, 3, stride=1, padding=1)
        score = score * (score >= peak).to(score.dtype)
        boxes = decode_boxes(reg)
        b = x.shape[0]
        return torch.cat([boxes, score], dim=1).reshape(b, 4 + self.net.num_classes, -1)
