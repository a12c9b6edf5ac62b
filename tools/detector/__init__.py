"""The shipped detector: its network, training data, training loop, ONNX export and evaluation.

Needs the ``train`` extra (torch) for ``model``, ``data`` and ``train``; ``evaluate``
needs only onnxruntime (it runs the exported model through ``perception``).
"""
