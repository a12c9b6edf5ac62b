"""Model soups: the weighted mean of checkpoints, exported as a model the detector runs; bad input
is one line and exit 2."""

from __future__ import annotations

import json

import numpy as np
import onnx
import pytest

torch = pytest.importorskip("torch")

from lookahead.perception.detectors.onnx_detector import OnnxDetector  # noqa: E402
from lookahead.tools.detector.arch import ArchitectureError  # noqa: E402
from lookahead.tools.detector.model import CenterDet  # noqa: E402
from lookahead.tools.detector.soup import average_checkpoints, soup, soup_weights  # noqa: E402

SMALL = {"widths": (8, 16, 24, 32, 40), "neck": 16, "head": 8}


def _checkpoint(path, seed: int, arch: dict = SMALL):
    torch.manual_seed(seed)
    net = CenterDet(**arch)
    with torch.no_grad():  # BatchNorm statistics as training leaves them, not the defaults
        for m in net.modules():
            if isinstance(m, torch.nn.BatchNorm2d):
                m.running_mean.uniform_(-1, 1)
                m.running_var.uniform_(0.5, 2)
                m.num_batches_tracked.fill_(seed)
    torch.save(net.state_dict(), path)
    return net.state_dict()


def test_the_soup_is_the_weighted_mean_of_every_float_tensor(tmp_path):
    a, b = _checkpoint(tmp_path / "a.pt", 1), _checkpoint(tmp_path / "b.pt", 2)
    mean = average_checkpoints([tmp_path / "a.pt", tmp_path / "b.pt"], [3, 1])  # normalised to 0.75, 0.25
    for k, v in mean.items():
        if v.is_floating_point():
            torch.testing.assert_close(v, 0.75 * a[k] + 0.25 * b[k])
        else:
            assert torch.equal(v, b[k])  # counters: the last checkpoint's
    assert soup_weights(2, None) == [0.5, 0.5]


def test_a_soup_exports_a_model_the_detector_runs_and_says_what_it_is_made_of(tmp_path):
    _checkpoint(tmp_path / "a.pt", 1)
    _checkpoint(tmp_path / "b.pt", 2)
    out = soup([tmp_path / "a.pt", tmp_path / "b.pt"], tmp_path / "soup.onnx")
    assert (tmp_path / "soup.pt").is_file()  # to fine-tune or average further
    meta = {p.key: p.value for p in onnx.load(str(out)).metadata_props}
    assert [r["weight"] for r in json.loads(meta["soup"])] == [0.5, 0.5]
    det = OnnxDetector(out, conf_threshold=0.0)
    d = det.detect(np.full((360, 640, 3), 90, np.uint8))
    assert np.all(np.isfinite(d.xyxy)) and len(d.xyxy) > 0
    # the exported graph computes the averaged network
    net = CenterDet(**SMALL)
    net.load_state_dict(torch.load(tmp_path / "soup.pt", weights_only=True))
    mean = average_checkpoints([tmp_path / "a.pt", tmp_path / "b.pt"])
    for k, v in net.state_dict().items():
        torch.testing.assert_close(v, mean[k])


def test_checkpoints_of_different_architectures_cannot_be_averaged(tmp_path):
    _checkpoint(tmp_path / "a.pt", 1)
    _checkpoint(tmp_path / "wide.pt", 2, {**SMALL, "head": 16})
    with pytest.raises(ArchitectureError, match="differs"):
        average_checkpoints([tmp_path / "a.pt", tmp_path / "wide.pt"])
    with pytest.raises(ValueError, match="one weight per checkpoint"):
        soup_weights(2, [1.0])
    with pytest.raises(ValueError, match="non-negative"):
        soup_weights(2, [1.0, -1.0])


def test_soup_detector_bad_input_is_one_line_and_exit_2(tmp_path):
    from typer.testing import CliRunner

    from lookahead.tools.cli import app

    _checkpoint(tmp_path / "a.pt", 1)
    (tmp_path / "notes.pt").write_text("not a checkpoint")
    out = str(tmp_path / "m.onnx")
    for args, said in (
        ([str(tmp_path / "a.pt"), str(tmp_path / "gone.pt")], "gone.pt: no such checkpoint"),
        ([str(tmp_path / "a.pt"), str(tmp_path / "notes.pt")], "notes.pt: not a checkpoint"),
        ([str(tmp_path / "a.pt"), str(tmp_path / "a.pt"), "--weights", "1,x"], "--weights '1,x'"),
    ):
        res = CliRunner().invoke(app, ["soup-detector", *args, "--out", out])
        assert res.exit_code == 2 and said in res.output and "Traceback" not in res.output, res.output
    res = CliRunner().invoke(app, ["soup-detector", str(tmp_path / "a.pt"), str(tmp_path / "a.pt"), "--out", out])
    assert res.exit_code == 0 and (tmp_path / "m.onnx").is_file()
