"""Write the ONNX twin of every shipped policy: ``checkpoints/<name>.onnx`` beside ``<name>.pt``.

    python scripts/export_onnx.py [--float64] [POLICY.pt ...]

With no files every shipped ``.pt`` (``baselines/ppo_gail/checkpoints``) is exported;
otherwise the files given, each to the same path with ``.onnx``. ``--float64`` first writes each file
to act in float64 (``policy.write_in_float64``), as every file written now does, for a policy trained
before that which will not be trained again: its records must then be played again
(``bash scripts/make_results.sh learned BASELINE``). The twins run with ``--baseline
onnx --config '{"file": ".../<name>.onnx"}'`` and give the torch policies' actions: to the bit where
the file acts in float64 (its ``inference``, tests/test_onnx_training.py), to 1e-5 in the shipped
float32 files (tests/test_onnx_baseline.py). A file that has no twin (a float64 policy whose activation
onnxruntime cannot run in float64) is said in a line, and the exit status is 1. Needs
``pip install "cabinbench[train,onnx]"``.
"""

from __future__ import annotations

import sys
from pathlib import Path

from cabinbench.baselines.onnx.export import export_onnx
from cabinbench.baselines.ppo_gail.policy import CHECKPOINT_DIR, PolicyFileError, write_in_float64


def main(argv: list[str]) -> int:
    float64 = "--float64" in argv
    policies = [Path(name) for name in argv if name != "--float64"] or sorted(CHECKPOINT_DIR.glob("*.pt"))
    status = 0
    for policy in policies:
        try:
            if float64:
                write_in_float64(policy)
            print(export_onnx(policy, policy.with_suffix(".onnx")))
        except PolicyFileError as error:
            print(error, file=sys.stderr)
            status = 1
    return status


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
