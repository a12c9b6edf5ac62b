"""``lookahead train-detector``: train ``CenterDet`` on exported COCO splits and export ONNX.

Loss (CenterNet): penalty-reduced focal loss on the class heat maps (alpha 2, beta 4,
normalised by the number of objects, masked over ignored boxes) + L1 on the
centre offset (``model.cell_offset``, as the decoder applies it) and on log(w),
log(h) (cells) + (1 - IoU) of the decoded box with the true one, at each object's
2 x 2 regression cells (``data.encode``). The IoU term weighs what AP50 counts:
relative box error, the same for a 5 px dog and a 300 px bus.

Optimiser: AdamW, linear warm-up then cosine decay, batches of random crops
(``tools.detector.data.TrainSampler``), channels-last tensors (faster convolutions
on CPU). Every draw comes from ``seed`` (crop sampling, augmentation, init), and
torch runs deterministic algorithms; on this CPU the same command gives the same
weights (thread scheduling aside, bit-exactness is not promised across machines).

After every epoch the run writes, beside ``out``, the weights (``.pt``, for
``--init``) and its whole training state (``.state.pt``: weights, AdamW moments,
step, the sampler's random state, the log so far); a run started from an exported
``.onnx`` also writes the weights it started from (``.init.pt``, ``init_checkpoint``), to
average with its own (``soup-detector``). ``resume=True`` continues an
interrupted run from that state -- the same command with ``--resume`` -- and ends
with the weights the uninterrupted run would have (tested); a run of several
hours can so span several sittings.

The exported ONNX (opset 17) takes ``images`` (1, 3, 384, 640) float RGB in [0, 1]
and gives ``output0`` (1, 4 + 8, 15360) in the YOLOv8 layout (``model.Decoded``),
with Ultralytics-style metadata (``names``, ``stride``, ``imgsz``) plus how it was
trained (``lookahead`` version, data, epochs, seed).

torch (the ``train`` extra) is imported inside the functions that use it, so this module
imports without it (the CLI's error handling reads ``ResumeError``; ``TrainConfig``).
"""

from __future__ import annotations

import copy
import json
import logging
import math
import time
from collections.abc import Sequence
from concurrent.futures import ThreadPoolExecutor
from dataclasses import asdict, dataclass
from importlib import metadata as md
from pathlib import Path

import numpy as np

from lookahead.perception.detections import CLASSES
from lookahead.tools.detector.arch import BLOCKS, HEAD, NECK, WIDTHS, ArchitectureError
from lookahead.tools.detector.data import SCALE_RANGE, TrainSampler, load_split, load_splits

log = logging.getLogger(__name__)

CALIBRATION_BATCHES = 16  # batches measured to unfold BatchNorm when starting from an exported .onnx


@dataclass
class TrainConfig:
    epochs: int = 12
    batch: int = 16
    crop: tuple[int, int] = (256, 384)  # px (h, w), multiples of 32
    scale: tuple[float, float] = SCALE_RANGE  # frames rescaled by a log-uniform factor in this range
    lr: float = 2e-3
    weight_decay: float = 1e-4
    warmup_steps: int = 200
    seed: int = 0
    threads: int = 2
    eval_every: int = 4  # epochs; 0 = only at the end
    limit: int | None = None  # use only the first N training images (smoke tests)
    init: str | None = None  # start from this checkpoint (state dict .pt, or an exported .onnx) instead of random
    balance: float = 0.5  # crops centre on an object of class c with weight freq(c) ** -balance (``TrainSampler``)
    # the network (``model.CenterDet``): channels at strides 2..32, neck, head, residual blocks
    # added at strides 4..32; an ``init`` of smaller widths or fewer blocks is grown into these
    # (``arch.grow``: the same function to start with)
    widths: tuple[int, ...] = WIDTHS
    neck: int = NECK
    head: int = HEAD
    blocks: tuple[int, ...] = BLOCKS

    def architecture(self) -> dict:
        return {"widths": tuple(self.widths), "neck": self.neck, "head": self.head, "blocks": tuple(self.blocks)}


def focal_loss(logits, heat, mask):
    """CenterNet's penalty-reduced focal loss (sum over cells / number of positives)."""
    # lazy: torch is the optional extra 'train'
    import torch
    from torch.nn import functional as F

    pos = heat.eq(1.0).float()
    neg = (1.0 - pos) * mask
    logp, log1mp = F.logsigmoid(logits), F.logsigmoid(-logits)
    p = torch.sigmoid(logits)
    pos_loss = -(log1mp.new_ones(()) - p).pow(2) * logp * pos
    neg_loss = -(1.0 - heat).pow(4) * p.pow(2) * log1mp * neg
    n = pos.sum().clamp(min=1.0)
    return (pos_loss.sum() + neg_loss.sum()) / n


def box_iou_cxcywh(a, b):
    """IoU of boxes given as (..., 4) centre x, y and size w, h (same units)."""
    # lazy: torch is the optional extra 'train'
    import torch

    lo = torch.maximum(a[..., :2] - a[..., 2:] / 2, b[..., :2] - b[..., 2:] / 2)
    hi = torch.minimum(a[..., :2] + a[..., 2:] / 2, b[..., :2] + b[..., 2:] / 2)
    inter = (hi - lo).clamp(min=0).prod(-1)
    union = a[..., 2:].prod(-1) + b[..., 2:].prod(-1) - inter
    return inter / union.clamp(min=1e-9)


def reg_loss(reg, index, target, valid):
    """L1 of offset and log size + (1 - IoU) at the objects' regression cells (mean over entries)."""
    # lazy: torch (and model, built on it) is the optional extra 'train'
    import torch

    from lookahead.tools.detector.model import cell_offset, cell_size

    b, c = reg.shape[:2]
    flat = reg.reshape(b, c, -1).permute(0, 2, 1)  # (B, HW, 4)
    pred = torch.gather(flat, 1, index[..., None].expand(-1, -1, c))  # (B, K, 4)
    off = cell_offset(pred[..., :2])
    err = torch.cat([off - target[..., :2], pred[..., 2:] - target[..., 2:]], dim=-1).abs().sum(-1)
    box_p = torch.cat([off, cell_size(pred[..., 2:])], dim=-1)
    box_t = torch.cat([target[..., :2], torch.exp(target[..., 2:])], dim=-1)
    err = err + (1.0 - box_iou_cxcywh(box_p, box_t))
    n = valid.sum().clamp(min=1.0)
    return (err * valid).sum() / n


def export_onnx(net, path: Path, metadata: dict[str, str], input_hw: tuple[int, int] = (384, 640)) -> Path:
    """Write the decoded graph (``model.Decoded``) as ONNX opset 17 with ``metadata``; its input
    height and width are dynamic (multiples of 32; ``input_hw`` is the traced size and the
    ``imgsz`` the detector fits a whole frame into), so zoom windows run at their own size."""
    # lazy: torch (and model) is the optional extra 'train'; onnx (~0.7 s to import) only to export
    import onnx
    import torch

    from lookahead.tools.detector.model import Decoded

    net = net.eval()
    dec = Decoded(net).eval()
    x = torch.zeros(1, 3, *input_hw)
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = path.with_suffix(".tmp.onnx")
    with torch.no_grad():
        torch.onnx.export(dec, x, str(tmp), opset_version=17, input_names=["images"],
                          output_names=["output0"], dynamo=False, do_constant_folding=True,
                          dynamic_axes={"images": {2: "height", 3: "width"}, "output0": {2: "cells"}})
    model = onnx.load(str(tmp))
    for k, v in metadata.items():
        entry = model.metadata_props.add()
        entry.key, entry.value = k, v
    onnx.checker.check_model(model)
    onnx.save(model, str(path))
    tmp.unlink(missing_ok=True)
    return path


def model_metadata(cfg: TrainConfig | None, data: str | None, extra: dict | None = None) -> dict[str, str]:
    """The exported model's metadata: what ``OnnxDetector`` reads (names, stride, imgsz), and how
    it was made (the training data and configuration, when trained; ``extra``)."""
    names = {i: n for i, n in enumerate(CLASSES)}
    meta = {
        "names": str(names), "stride": "4", "imgsz": "[384, 640]", "task": "detect",
        "description": "lookahead CenterDet (stride-4 CenterNet head, YOLOv8 output layout)",
        "lookahead_version": md.version("lookahead"),
    }
    if data is not None:
        meta["train_data"] = data
    if cfg is not None:
        meta["train_config"] = json.dumps(asdict(cfg))
    meta.update({k: str(v) for k, v in (extra or {}).items()})
    return meta


def lr_at(step: int, total: int, cfg: TrainConfig) -> float:
    if step < cfg.warmup_steps:
        return cfg.lr * (step + 1) / cfg.warmup_steps
    t = (step - cfg.warmup_steps) / max(1, total - cfg.warmup_steps)
    return cfg.lr * (0.02 + 0.98 * 0.5 * (1 + math.cos(math.pi * t)))


class ResumeError(ValueError):
    """A training state that does not belong to this run (one line: file and what differs)."""


def state_path(out: Path) -> Path:
    """The training state written beside the model ``out`` after every epoch."""
    return Path(out).with_suffix(".state.pt")


def _data_dirs(data: str | Path | Sequence[str | Path]) -> list[Path]:
    return [Path(data)] if isinstance(data, str | Path) else [Path(d) for d in data]


def _data_name(data: str | Path | Sequence[str | Path]) -> str:
    """The training data as the log and the model's metadata name it: a directory, or several joined by ','."""
    return ",".join(str(d) for d in _data_dirs(data))


def _run_identity(cfg: TrainConfig, data: str | Path | Sequence[str | Path]) -> dict:
    """What a saved state must share with the run resuming it: the data and every option."""
    dirs = [str(d.resolve()) for d in _data_dirs(data)]
    options = {k: list(v) if isinstance(v, tuple) else v for k, v in asdict(cfg).items()}
    return {"data": dirs[0] if len(dirs) == 1 else dirs, **options}


def _load_state(path: Path, cfg: TrainConfig, data_dir: str | Path | Sequence[str | Path]) -> dict:
    # lazy: torch is the optional extra 'train'
    import torch

    if not path.is_file():
        raise FileNotFoundError(f"{path}: no training state to resume (it is written after each epoch)")
    try:  # tensors, numbers, strings and containers only: a state file cannot run code
        state = torch.load(path, map_location="cpu", weights_only=True)
    except Exception as exc:  # noqa: BLE001 -- UnpicklingError, a truncated zip, a text file: the same mistake
        raise ResumeError(f"{path}: not a training state this tool wrote ({str(exc).splitlines()[0]:.120})") from None
    if not isinstance(state, dict) or not isinstance(state.get("run"), dict) or "epoch" not in state:
        raise ResumeError(f"{path}: not a training state this tool wrote (no run or epoch)")
    was, now = state["run"], _run_identity(cfg, data_dir)
    diff = [f"{k}={was.get(k)!r} (now {now[k]!r})" for k in now if was.get(k) != now[k]]
    if diff:
        raise ResumeError(f"{path}: written by a different run: " + ", ".join(diff))
    if state["epoch"] >= cfg.epochs:
        raise ResumeError(f"{path}: nothing to resume, all {cfg.epochs} epochs are done")
    return state


def _save_state(path: Path, state: dict) -> None:
    # lazy: torch is the optional extra 'train'
    import torch

    tmp = path.with_suffix(".tmp")
    torch.save(state, tmp)
    tmp.replace(path)  # a crash while writing leaves the previous epoch's state


def init_checkpoint(out: str | Path) -> Path:
    """Where a run started from an exported ``.onnx`` saves the weights it started from
    (BatchNorm unfolded, ``from_onnx``), so that ``soup-detector`` can average them with the
    run's own ``.pt``: ``OUT.init.pt`` beside ``OUT.onnx``."""
    return Path(out).with_suffix(".init.pt")


def _read_init_weights(init: Path) -> dict:
    """The state dict of a ``--init`` ``.pt`` file (tensors only: a weights file cannot run code);
    ``ArchitectureError`` naming the file when it is not one. Read before any data is."""
    # lazy: torch is the optional extra 'train'
    import torch

    try:
        weights = torch.load(init, map_location="cpu", weights_only=True)
    except Exception as e:  # noqa: BLE001 -- any unreadable file is the same user mistake
        raise ArchitectureError(f"--init {init}: not a weights file ({type(e).__name__})") from None
    if not isinstance(weights, dict) or not all(hasattr(v, "shape") for v in weights.values()):
        raise ArchitectureError(f"--init {init}: not a state dict of tensors")
    return weights


def _initial_network(net, init: Path, cfg: TrainConfig, sampler, n_images: int, weights: dict | None):
    """``net`` (freshly initialised) started from ``init`` (``weights``: its state dict, for a
    ``.pt``): its weights, grown when narrower or shallower."""
    # lazy: torch (and growth, model, built on it) is the optional extra 'train'
    import torch

    from lookahead.tools.detector.growth import architecture, grow
    from lookahead.tools.detector.model import CenterDet

    if init.suffix == ".onnx":  # an exported model (BatchNorm folded): unfold it
        # lazy: torch, and onnx only when starting from an exported model
        from lookahead.tools.detector.from_onnx import exported_architecture, load_exported

        src = CenterDet(**exported_architecture(init))
        calib_rng = np.random.default_rng([cfg.seed, 2])
        calib = (torch.from_numpy(sampler.batch(calib_rng.choice(n_images, cfg.batch))[0])
                 .float().div_(255.0) for _ in range(CALIBRATION_BATCHES))
        load_exported(src, init, calib)
    else:
        weights = _read_init_weights(init) if weights is None else weights
        try:
            src = CenterDet(**architecture({k: tuple(v.shape) for k, v in weights.items()}))
        except ArchitectureError as e:
            raise ArchitectureError(f"{init}: {e}") from None
        src.load_state_dict(weights)
    if src.arch != net.arch:
        log.info("%s: grown from %s to %s", init, src.arch, net.arch)
    try:
        return grow(src, net)
    except ArchitectureError as e:
        raise ArchitectureError(f"--init {init}: {e}") from None


def train(data_dir: str | Path | Sequence[str | Path], out: Path, cfg: TrainConfig, progress=None,
          resume: bool = False) -> dict:
    """Train on ``data_dir/train`` (validating on ``data_dir/val`` when present); write ``out`` (ONNX).

    ``data_dir`` may be several dataset directories: their ``train`` splits are read as one
    (``data.load_splits``), validation is the first one's ``val``.

    ``resume``: continue from ``state_path(out)``, which must come from this very
    configuration and data. Returns the training log: per-epoch losses and
    validation metrics, seconds.
    """
    # lazy: torch (and model) is the optional extra 'train'
    import torch

    # lazy: evaluate reads runs through tools.scoring, which loads the simulator (highway-env)
    from lookahead.tools.detector.evaluate import evaluate_model
    from lookahead.tools.detector.model import CenterDet

    state = _load_state(state_path(out), cfg, data_dir) if resume else None
    init = None if state is not None else cfg.init  # a resumed run takes its weights from the state
    init_weights = _read_init_weights(Path(init)) if init and Path(init).suffix != ".onnx" else None
    torch.manual_seed(cfg.seed)
    torch.set_num_threads(cfg.threads)
    torch.use_deterministic_algorithms(True, warn_only=True)
    dirs = _data_dirs(data_dir)
    train_split = load_splits([d / "train" for d in dirs], cfg.limit)
    val_dir = dirs[0] / "val"
    if val_dir.is_dir():  # a broken validation split fails now, not after the first epochs
        load_split(val_dir)
    sampler = TrainSampler(train_split, cfg.crop, len(CLASSES), cfg.seed, balance=cfg.balance,
                           scale_range=cfg.scale)
    net = CenterDet(len(CLASSES), **cfg.architecture())
    if init:
        net = _initial_network(net, Path(init), cfg, sampler, len(train_split.images), init_weights)
        if Path(init).suffix == ".onnx":  # its unfolded weights: a checkpoint to average with (soup)
            torch.save(net.state_dict(), init_checkpoint(out))
    net = net.to(memory_format=torch.channels_last)
    checkpoint = Path(out).with_suffix(".pt")  # weights after every epoch (to resume or fine-tune)
    decay = [p for n, p in net.named_parameters() if p.ndim > 1]
    no_decay = [p for n, p in net.named_parameters() if p.ndim <= 1]
    opt = torch.optim.AdamW([{"params": decay, "weight_decay": cfg.weight_decay},
                             {"params": no_decay, "weight_decay": 0.0}], lr=cfg.lr)
    n = len(train_split.images)
    steps_per_epoch = max(1, n // cfg.batch)
    total = steps_per_epoch * cfg.epochs
    order_rng = np.random.default_rng([cfg.seed, 1])
    history: list[dict] = []
    step, first_epoch, elapsed = 0, 0, 0.0
    if state is not None:
        net.load_state_dict(state["net"])
        opt.load_state_dict(state["opt"])
        sampler.rng.bit_generator.state = state["sampler_rng"]
        torch.set_rng_state(state["torch_rng"])
        step, first_epoch, elapsed, history = state["step"], state["epoch"], state["seconds"], state["history"]
        log.info("resuming %s after epoch %d of %d", state_path(out), first_epoch, cfg.epochs)
    t_start = time.perf_counter() - elapsed
    prefetch = ThreadPoolExecutor(1)  # the next batch is cut (numpy/OpenCV, GIL released) during this step
    batches = [order_rng.permutation(n) for _ in range(cfg.epochs)]
    plan = [(e, p[b * cfg.batch:(b + 1) * cfg.batch]) for e, p in enumerate(batches) for b in range(steps_per_epoch)]
    pending = prefetch.submit(sampler.batch, plan[step][1])
    for epoch in range(first_epoch, cfg.epochs):
        net.train()
        sums = np.zeros(3)
        for i in range(steps_per_epoch):
            x, t = pending.result()
            if i + 1 < steps_per_epoch:  # the next epoch's first batch is cut after the state is saved
                pending = prefetch.submit(sampler.batch, plan[step + 1][1])
            xt = torch.from_numpy(x).float().div_(255.0).contiguous(memory_format=torch.channels_last)
            tt = {k: torch.from_numpy(v) for k, v in t.items()}
            for g in opt.param_groups:
                g["lr"] = lr_at(step, total, cfg)
            heat, reg = net(xt)
            lh = focal_loss(heat, tt["heat"], tt["mask"][:, None])
            lr_ = reg_loss(reg, tt["index"], tt["reg"], tt["valid"])
            loss = lh + lr_
            opt.zero_grad(set_to_none=True)
            loss.backward()
            torch.nn.utils.clip_grad_norm_(net.parameters(), 10.0)
            opt.step()
            sums += (loss.item(), lh.item(), lr_.item())
            step += 1
            if progress:
                progress(step / total)
        mean = [round(float(v) / steps_per_epoch, 4) for v in sums]
        entry = {"epoch": epoch + 1, "loss": mean[0], "heat": mean[1], "reg": mean[2],
                 "s": round(time.perf_counter() - t_start, 1)}
        torch.save(net.state_dict(), checkpoint)
        last = epoch + 1 == cfg.epochs
        sampler_rng = copy.deepcopy(sampler.rng.bit_generator.state)
        if not last:
            pending = prefetch.submit(sampler.batch, plan[step][1])
        if val_dir.is_dir() and (last or (cfg.eval_every and (epoch + 1) % cfg.eval_every == 0)):
            export_onnx(net, out, model_metadata(cfg, _data_name(data_dir)))
            m = evaluate_model(out, val_dir)
            entry["val"] = {k: m[k] for k in ("ap50", "ap50_pooled", "recall_at_p95", "precision", "recall")}
            net.to(memory_format=torch.channels_last)
        log.info("epoch %s", entry)
        history.append(entry)
        _save_state(state_path(out), {
            "run": _run_identity(cfg, data_dir), "epoch": epoch + 1, "step": step,
            "seconds": round(time.perf_counter() - t_start, 1), "history": history, "net": net.state_dict(),
            "opt": opt.state_dict(), "sampler_rng": sampler_rng, "torch_rng": torch.get_rng_state(),
        })
    prefetch.shutdown()
    seconds = time.perf_counter() - t_start
    export_onnx(net, out, model_metadata(cfg, _data_name(data_dir), {"train_seconds": round(seconds, 1)}))
    return {"config": asdict(cfg), "images": n, "seconds": round(seconds, 1), "history": history, "model": str(out),
            "checkpoint": str(checkpoint)}
