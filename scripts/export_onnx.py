"""Write the ONNX twin of every shipped policy: ``checkpoints/<name>.onnx`` beside ``<name>.pt``.

    python scripts/export_onnx.py [POLICY.pt ...]

With no arguments every shipped ``.pt`` (``baselines/ppo_gail/checkpoints``) is exported;
otherwise the files given, each to the same path with ``.onnx``. The twins run with ``--baseline
onnx --config '{"file": ".../<name>.onnx"}'`` and give the torch policies' actions
(tests/test_onnx_baseline.py). Needs ``pip install "cabinbench[train,onnx]"``.
"""

from __future__ import annotations

import sys
from pathlib import Path

from cabinbench.baselines.onnx.export import export_onnx
from cabinbench.baselines.ppo_gail.policy import CHECKPOINT_DIR


def main(argv: list[str]) -> int:
    policies = [Path(name) for name in argv] or sorted(CHECKPOINT_DIR.glob("*.pt"))
    for policy in policies:
        print(export_onnx(policy, policy.with_suffix(".onnx")))
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
