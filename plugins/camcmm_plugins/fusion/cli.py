"""``camcmm fuse csi --cloud PHOTO.ply --csi MAP [--csi MAP2 ...] [--sigma-px 6]
[--reject similarity|fundamental] [--out fused.ply] [--report DIR] [--project DIR] [--json]``
and ``camcmm fuse sample DIR``.

``camcmm fuse sample DIR`` writes the sample pair (plugin ``fusion.sample``, the synthetic
coin exact by construction) as ``DIR/coin_photogrammetry.ply`` and ``DIR/coin_csi.x3p``
(with its intensity channel) and ``DIR/coin_truth.json`` (the construction: scale 1.02, the
poses); ``camcmm fuse csi --cloud DIR/coin_photogrammetry.ply --csi DIR/coin_csi.x3p`` fuses
them at the default parameters and recovers the scale 1.02. JSON keys: ``sample``
{``cloud``, ``csi``, ``truth``} (the files written), ``command`` (the fusion to run).

Runs the plugin that provides ``csi-fusion`` (camcmm's ``fusion.csi``) through the host (so
the result carries its provenance); its declared parameters are the options, with the
manifest's help, limits and defaults (``camcmm fuse csi --help``: ``--sigma-px``, ``--grey``,
``--reject``, ``--grid``, ``--ransac-px``, ``--min-inliers``, ``--ratio``,
``--icp-iterations``, ``--icp-max-distance``, ``--icp-points``, ``--max-points``, ``--seed``).
The fusion registers each CSI height map (Zygo .dat/.datx, Wyko .opd, Sensofar .plu, .sur,
.x3p, .sdf ...) onto the coloured photogrammetry cloud, fixes the cloud's scale from the
CSI's lateral scale and merges them. JSON keys (lengths in mm): ``maps`` [{``file``, ``n_matches``,
``n_inliers``, ``transform2d`` {``angle_deg``, ``tx``, ``ty`` (px of the cloud's image),
``scale``}, ``icp`` {``tz``, ``rx_deg``, ``ry_deg``, ``rms``, ``converged``}, ``difference``
{``mean``, ``std``, ``p2_5``, ``p97_5``}, ``material_ratio`` {``Sk``, ``Spk``, ``Svk``,
``Smr1``, ``Smr2``}, + ``n_inliers_similarity``, ``n_inliers_fundamental``, ``transform``
(4×4 map -> fused cloud)}], ``photogrammetry_scale`` {``value``, ``std``},
``n_points_fused``, ``warnings``, + ``timings``, ``plane``, ``plugin``, ``written``,
``report``, ``result_id``.

Bad input (a map with no overlap, too few matches, a wrong unit, a missing file) exits 2
with one line naming the file, and writes nothing: ``--out``, ``--report`` and
``--project`` are written only after the whole fusion succeeded.
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path
from typing import Any

from camcmm.api import (
    InputError,
    add_declared_options,
    checked_path,
    declared_values,
    default_host,
    numbers,
    record_result,
    write,
)

#: The task ``camcmm fuse csi`` runs: its provider's parameters are the command's options.
TASK = "csi-fusion"
#: The task ``camcmm fuse sample`` runs: a cloud and a map that fuse at the defaults.
SAMPLE_TASK = "csi-fusion-sample"


def configure(parser: argparse.ArgumentParser) -> None:
    sub = parser.add_subparsers(dest="what", required=True, metavar="{csi,sample}")
    smp = sub.add_parser(
        "sample", help="write a sample pair (a cloud and a CSI map of a synthetic coin) that fuses at the defaults"
    )
    smp.add_argument("folder", metavar="DIR", help="the folder to write them in (made if absent)")
    smp.add_argument("--json", action="store_true", default=argparse.SUPPRESS, help="print one JSON document")
    c = sub.add_parser("csi", help="fuse CSI height maps with a photogrammetry cloud (thesis ch. 6.1)")
    c.add_argument("--cloud", required=True, metavar="PHOTO", help="the coloured photogrammetry cloud (.ply ...)")
    c.add_argument(
        "--csi", required=True, action="append", metavar="MAP", help="a height map (.dat .opd .plu .x3p ...); repeat"
    )
    c.add_argument("--datum", default=None, metavar="FILE", help='JSON {"point": [x,y,z], "normal": [nx,ny,nz]}')
    # --sigma-px, --grey, --reject, --grid, --ransac-px ... --seed: every declared parameter
    # of the fusion, with the manifest's help, unit, limits and default
    add_declared_options(c, default_host().provider(TASK).parameters)
    c.add_argument("--out", metavar="fused.ply", help="write the fused cloud (field 'source')")
    c.add_argument("--report", metavar="DIR", help="write report.html, report.pdf, report.json here")
    c.add_argument("--project", metavar="DIR", help="record the result in this project folder")
    c.add_argument("--json", action="store_true", default=argparse.SUPPRESS, help="print one JSON document on stdout")


def run(args: argparse.Namespace) -> dict[str, Any]:
    if args.what == "sample":
        return sample(args.folder)
    host = default_host()
    params = declared_values(args, host.provider(TASK).parameters)  # checked first: a bad value reads no file
    for f in [args.cloud, *args.csi, *([args.datum] if args.datum else [])]:
        if not Path(f).is_file():
            raise InputError(f"{f}: no such file")
    inputs: dict[str, Any] = {"cloud": args.cloud, "csi": list(args.csi)}
    if args.datum:
        inputs["datum"] = args.datum
    res = host.run_task(TASK, inputs, params)
    o = res.outputs
    out = dict(o["result"])
    out["warnings"] = list(res.warnings)
    out["plugin"] = res.provenance()
    if args.report:  # rendered in memory first: a failure writes nothing
        from .report import build_report

        rep = build_report(o, cloud_file=args.cloud, run=res)
    if args.out:
        write(o["fused"], args.out)
        out["written"] = {"fused": str(args.out)}
    if args.report:
        out["report"] = rep.write(args.report)
    if args.project:
        out["result_id"] = record_result(args.project, res)
    return out


def sample(folder: str | Path) -> dict[str, Any]:
    """The sample pair written into ``folder`` (its files' names from
    :mod:`.sample`): ``{"sample": {cloud, csi, truth}, "command": "camcmm fuse csi ..."}``."""
    from .sample import CLOUD_FILE, MAP_FILE

    out = Path(checked_path(folder, "sample folder"))
    if out.exists() and not out.is_dir():
        raise InputError(f"{folder}: not a folder")
    o = default_host().run_task(SAMPLE_TASK, {}, {}).outputs
    out.mkdir(parents=True, exist_ok=True)
    files = {"cloud": out / CLOUD_FILE, "csi": out / MAP_FILE, "truth": out / "coin_truth.json"}
    write(o["cloud"], files["cloud"])
    write(o["csi"], files["csi"])
    files["truth"].write_text(json.dumps(o["truth"], indent=1) + "\n", encoding="utf-8")
    command = f"camcmm fuse csi --cloud {files['cloud']} --csi {files['csi']}"
    return {"sample": {k: str(v) for k, v in files.items()}, "command": command}


def _dev(x: float | None, signed: bool = True) -> str:
    """A difference or roughness (mm) in µm by the number rule; "—" when the run has none."""
    return "—" if x is None else numbers.deviation(x, signed=signed)


def text(r: dict[str, Any]) -> str:
    """Human-readable summary of :func:`run` (numbers by the one number rule)."""
    if "sample" in r:
        return "\n".join(
            [f"wrote the sample pair: {r['sample']['cloud']}, {r['sample']['csi']} (truth: {r['sample']['truth']})"]
            + [f"fuse them (default parameters): {r['command']}"]
        )
    s = r["photogrammetry_scale"]
    std = "" if s["std"] is None else f" ± {numbers.plain(s['std'], 2)}"
    lines = [
        f"fused {len(r['maps'])} CSI map(s): {numbers.count(r['n_points_fused'])} points; "
        f"photogrammetry scale {numbers.plain(s['value'], 7)}{std}"
    ]
    for m in r["maps"]:
        t, i, d, mr = m["transform2d"], m["icp"], m["difference"], m["material_ratio"]
        lines.append(
            f"  {m['file']}: {m['n_inliers']} of {m['n_matches']} matches (similarity {m['n_inliers_similarity']}, "
            f"fundamental {m['n_inliers_fundamental']}; grey image: {m.get('grey', 'intensity')})"
        )
        lines.append(
            f"    2-D  angle {numbers.angle(t['angle_deg'], 'deg')}  t ({numbers.plain(t['tx'], 5)}, "
            f"{numbers.plain(t['ty'], 5)}) px  scale {numbers.plain(t['scale'], 7)}"
        )
        lines.append(
            f"    ICP  tz {numbers.length(i['tz'], signed=True)}  rx {numbers.angle(i['rx_deg'], 'deg')}  "
            f"ry {numbers.angle(i['ry_deg'], 'deg')}  rms {_dev(i['rms'], False)}"
            + ("" if i["converged"] else "  NOT CONVERGED")
        )
        lines.append(
            f"    CSI − photogrammetry  mean {_dev(d['mean'])}  std {_dev(d['std'], False)}  95 % {_dev(d['p2_5'])} … "
            f"{_dev(d['p97_5'])}"
        )
        if mr.get("Sk") is not None:
            lines.append(
                f"    material  Sk {_dev(mr['Sk'], False)}  Spk {_dev(mr['Spk'], False)}  "
                f"Svk {_dev(mr['Svk'], False)}  Smr1 {numbers.percent(mr['Smr1'] / 100)}  "
                f"Smr2 {numbers.percent(mr['Smr2'] / 100)}"
            )
    lines += [f"  warning: {w}" for w in r.get("warnings", [])]
    if r.get("written"):
        lines.append(f"  wrote {r['written']['fused']}")
    if r.get("report"):
        lines.append("  report " + ", ".join(r["report"].values()))
    return "\n".join(lines)
