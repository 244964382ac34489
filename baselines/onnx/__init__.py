"""``onnx``: any ONNX policy run with onnxruntime (no torch), and torch policy files' ONNX twins.

- ``policy``: ``OnnxPolicy`` (``--baseline onnx --config '{"file": "policy.onnx"}'``) and the model's
  metadata (observation settings, action std) it runs by.
- ``export``: ``export_onnx``, a ``ppo_gail`` policy file written as ONNX with that metadata (torch).
"""

from cabinbench.baselines.onnx.policy import OnnxModel, OnnxPolicy

__all__ = ["OnnxModel", "OnnxPolicy"]
