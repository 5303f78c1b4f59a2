"""``camcmm simulate SCENE.yaml --out DIR [--json]``

Renders a virtual-lab scene's capture sequence (see camcmm_plugins.virtuallab.scene_file
for the scene file and camcmm_plugins.virtuallab.capture for what DIR receives). JSON
keys ``out, cameras, n_frames, calibration, truth, sequence, coverage, warnings``
(+ ``files``).
"""

from __future__ import annotations

import argparse
from typing import Any


def configure(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("scene", help="scene file (YAML): artefacts, rig, lighting, sensor, sequence, errors")
    parser.add_argument("--out", required=True, metavar="DIR", help="folder for the frames, calibration and truth")


def run(args: argparse.Namespace) -> dict[str, Any]:
    from camcmm.api import get_algorithm

    return get_algorithm("virtuallab.capture")(scene=args.scene, out=args.out)


def text(result: dict[str, Any]) -> str:
    cov = ", ".join(
        f"{k}: {100 * v['surface']:.0f} % surface, {100 * v['lit']:.0f} % lit" for k, v in result["coverage"].items()
    )
    warn = "".join(f"\n  warning: {w}" for w in result.get("warnings", []))
    return (
        f"{result['n_frames']} frames x {len(result['cameras'])} cameras written to {result['out']}\n"
        f"  calibration: {result['calibration']}\n  truth: {result['truth']}\n  {cov}{warn}"
    )
