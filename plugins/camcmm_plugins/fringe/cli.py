"""``camcmm fringe patterns|reconstruct``

* ``patterns SEQUENCE.yaml --out DIR``: writes the sequence's frames as PNG files at the
  projector's resolution. JSON keys ``n_frames, projector_size, out, files, frames``.
* ``reconstruct SEQUENCE.yaml --images DIR [--images2 DIR] --calibration CAL.yaml
  [--json] [--out cloud.ply]``: decodes the captures (image files of DIR in natural sort
  order, one per frame) and triangulates. JSON keys ``n_points, valid_fraction, bbox``
  (+ ``method, order_errors_corrected, order_errors_dropped, warnings, out``).
"""

from __future__ import annotations

import argparse
import re
from pathlib import Path
from typing import Any

from camcmm.api import InputError

IMAGE_EXTS = (".png", ".bmp", ".tif", ".tiff", ".jpg", ".jpeg", ".pgm")
#: fringe.decode's thresholds (grey levels) and what their default 0 means
THRESHOLDS = {
    "black_threshold": "5 % of full scale",
    "modulation_threshold": "2 % of full scale",
    "white_threshold": "no such rule",
    "saturation": "the image type's maximum",
}


def configure(parser: argparse.ArgumentParser) -> None:
    sub = parser.add_subparsers(dest="what", required=True, metavar="{patterns,reconstruct}")
    p = sub.add_parser("patterns", help="write a sequence's projector frames as PNG files")
    p.add_argument("sequence", help="sequence file (YAML), see docs/fringe.md")
    p.add_argument("--out", required=True, metavar="DIR", help="folder for pat00.png ...")
    r = sub.add_parser("reconstruct", help="decode captured frames and triangulate a point cloud")
    r.add_argument("sequence", help="sequence file (YAML) the captures follow")
    r.add_argument("--images", required=True, metavar="DIR", help="camera 1's captures, one file per frame")
    r.add_argument("--images2", metavar="DIR", help="camera 2's captures (camera-camera matching)")
    r.add_argument(
        "--calibration",
        required=True,
        metavar="CAL",
        help="calibration file (.yaml/.xml/.json) or a CalibrationDataDistortion-style folder",
    )
    r.add_argument("--out", metavar="cloud.ply", help="write the point cloud here")
    r.add_argument("--method", choices=("auto", "projector", "stereo"), default="auto")
    # None: not given, the plugin's declared default applies
    for opt, zero in THRESHOLDS.items():
        r.add_argument(
            "--" + opt.replace("_", "-"),
            type=float,
            default=None,
            metavar="GREY",
            help=f"fringe.decode's {opt} (default 0: {zero})".replace("%", "%%"),
        )
    for sp in (p, r):
        sp.add_argument(
            "--json", action="store_true", default=argparse.SUPPRESS, help="print one JSON document on stdout"
        )


def image_files(folder: str | Path) -> list[Path]:
    """Image files of a folder in natural order (pat2 before pat10)."""
    d = Path(folder)
    if not d.is_dir():
        raise InputError(f"{d}: not a folder of images")
    files = [p for p in d.iterdir() if p.suffix.lower() in IMAGE_EXTS and p.is_file()]
    if not files:
        raise InputError(f"{d}: no image files ({', '.join(IMAGE_EXTS)})")

    def key(p: Path):
        return [int(t) if t.isdigit() else t.lower() for t in re.split(r"(\d+)", p.name)]

    return sorted(files, key=key)


def run(args: argparse.Namespace) -> dict[str, Any]:
    from .sequence import load_sequence

    seq = load_sequence(args.sequence)
    if args.what == "patterns":
        from .patterns import save_patterns

        files = save_patterns(seq, args.out)
        return {
            "n_frames": seq.n_frames,
            "projector_size": list(seq.projector_size),
            "out": str(args.out),
            "files": [str(f) for f in files],
            "frames": seq.describe(),
        }
    from camcmm.api import default_host, write

    files = image_files(args.images)
    inputs = {"sequence": str(args.sequence), "images": [str(f) for f in files], "calibration": str(args.calibration)}
    if args.images2:
        inputs["images2"] = [str(f) for f in image_files(args.images2)]
    given = {k: getattr(args, k) for k in THRESHOLDS if getattr(args, k) is not None}
    try:
        res = default_host().run("fringe.reconstruct", inputs, {"method": args.method, **given})
    except InputError as exc:
        if "no pixel decodes" not in str(exc) or not given:
            raise
        # the thresholds the operator set are the first suspects: name them
        named = ", ".join(
            f"--{k.replace('_', '-')} {v:g}" + (f" (0: {THRESHOLDS[k]})" if v == 0 else "") for k, v in given.items()
        )
        raise InputError(f"{exc} (given: {named})") from None
    o = res.outputs
    out = {
        "n_points": o["n_points"],
        "valid_fraction": o["valid_fraction"],
        "bbox": o["bbox"],
        "method": o.get("method", ""),
        "order_errors_corrected": o.get("order_errors_corrected", 0),
        "order_errors_dropped": o.get("order_errors_dropped", 0),
        "warnings": res.warnings,
    }
    if args.out:
        write(o["cloud"], args.out)
        out["out"] = str(args.out)
    return out


def text(result: dict[str, Any]) -> str:
    if "n_frames" in result:
        w, h = result["projector_size"]
        return f"{result['n_frames']} frames of {w}x{h} px written to {result['out']}"
    bb = result["bbox"]
    s = (
        f"{result['n_points']} points ({100 * result['valid_fraction']:.1f} % of the pixels valid, "
        f"{result.get('method', '')})"
    )
    if bb:
        s += "\n  bbox mm: " + " .. ".join("(" + ", ".join(f"{x:.3f}" for x in c) + ")" for c in bb)
    if result.get("out"):
        s += f"\n  written to {result['out']}"
    for w in result.get("warnings", []):
        s += f"\n  warning: {w}"
    return s
