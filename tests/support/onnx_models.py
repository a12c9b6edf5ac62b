"""Tiny real ONNX models built by the tests themselves (onnx.helper): a graph whose output is a
given array whatever its input holds, to test how a detector reads each output layout."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import onnx
from onnx import TensorProto, helper, numpy_helper


def save_model(path: Path, graph: onnx.GraphProto, metadata: dict[str, str] | None = None,
               producer: str | None = None) -> Path:
    """``graph`` as a checked opset-17 model at ``path``, with metadata properties and producer name."""
    model = helper.make_model(graph, opset_imports=[helper.make_opsetid("", 17)])
    model.ir_version = 9
    if producer is not None:
        model.producer_name = producer
    if metadata:
        helper.set_model_props(model, metadata)
    onnx.checker.check_model(model)
    onnx.save(model, path)
    return path


def constant_output_model(
    path: Path,
    output: np.ndarray,
    input_shape: list[int | str],
    metadata: dict[str, str] | None = None,
    producer: str | None = None,
    dynamic_output: list[str] | None = None,
) -> Path:
    """A model (input ``images`` of ``input_shape``) whose output ``output0`` is ``output``.

    ``dynamic_output``: the output's dimension names, its shape unknown until run time
    (``Reshape(flat constant, shape + 0 * max(images))``), e.g. ``["b", "f", "n"]``."""
    if dynamic_output is not None:
        consts = [("flat", output.reshape(-1)), ("shape", np.array(output.shape, np.float32)),
                  ("zero", np.array(0, np.float32))]
        nodes = [helper.make_node("Constant", [], [n], value=numpy_helper.from_array(v, n)) for n, v in consts]
        nodes += [
            helper.make_node("ReduceMax", ["images"], ["peak"], keepdims=0),
            helper.make_node("Mul", ["peak", "zero"], ["nil"]),
            helper.make_node("Add", ["shape", "nil"], ["shape_f"]),
            helper.make_node("Cast", ["shape_f"], ["shape_i"], to=TensorProto.INT64),
            helper.make_node("Reshape", ["flat", "shape_i"], ["output0"]),
        ]
        out_shape: list[int | str] = list(dynamic_output)
    else:
        nodes = [helper.make_node("Constant", [], ["output0"], value=numpy_helper.from_array(output, "c"))]
        out_shape = list(output.shape)
    graph = helper.make_graph(
        nodes, "const",
        [helper.make_tensor_value_info("images", TensorProto.FLOAT, input_shape)],
        [helper.make_tensor_value_info("output0", TensorProto.FLOAT, out_shape)],
    )
    return save_model(path, graph, metadata, producer)


def scaled_scores_model(source: Path, path: Path, factor: float) -> Path:
    """A copy of a YOLOv8-layout model (output ``[1, 4+C, N]``) whose class scores are multiplied by
    ``factor``: the same boxes and ranking, on another score scale -- a detector that scores low."""
    model = onnx.load(source)
    graph = model.graph
    old = graph.output[0].name
    raw = old + "_unscaled"
    for node in graph.node:  # the node that made the output now makes ``raw``
        node.output[:] = [raw if o == old else o for o in node.output]
    consts = {"starts_box": [0], "ends_box": [4], "starts_cls": [4], "ends_cls": [1 << 30], "axes": [1]}
    graph.initializer.extend(numpy_helper.from_array(np.array(v, np.int64), k) for k, v in consts.items())
    graph.initializer.append(numpy_helper.from_array(np.array(factor, np.float32), "score_factor"))
    graph.node.extend([
        helper.make_node("Slice", [raw, "starts_box", "ends_box", "axes"], ["boxes"]),
        helper.make_node("Slice", [raw, "starts_cls", "ends_cls", "axes"], ["cls"]),
        helper.make_node("Mul", ["cls", "score_factor"], ["cls_scaled"]),
        helper.make_node("Concat", ["boxes", "cls_scaled"], [old], axis=1),
    ])
    onnx.save(model, path)
    return path
