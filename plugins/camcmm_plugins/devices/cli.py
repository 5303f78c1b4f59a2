"""``camcmm devices list|simulate-stage``

* ``list [--ports]``: the device plugins (id, role, name, status, simulated) and, with
  ``--ports``, the serial ports pyserial finds. JSON keys ``devices`` (list of
  ``{id, role, name, status, simulated, summary}``) and ``ports`` (list of
  ``{port, description, hwid}``).
* ``simulate-stage [--tcp HOST:PORT] [--link PATH] [--rotary] [--interferometer] ...``:
  run the Zaber-ASCII stage simulator in the foreground; it prints ``STAGE <port>``
  (and ``INTERFEROMETER <port>``) then ``READY`` and serves until interrupted. Its
  fault commands are listed in :mod:`camcmm_plugins.devices.simulator`.
"""

from __future__ import annotations

import argparse
from typing import Any


def configure(parser: argparse.ArgumentParser) -> None:
    sub = parser.add_subparsers(dest="what", required=True, metavar="{list,simulate-stage}")
    ls = sub.add_parser("list", help="device plugins and serial ports")
    ls.add_argument("--ports", action="store_true", help="also list the serial ports")
    ls.add_argument("--json", action="store_true", default=argparse.SUPPRESS, help="print one JSON document")
    sim = sub.add_parser("simulate-stage", help="run the Zaber-ASCII stage simulator (pty or TCP)")
    from .simulator import configure as sim_configure

    sim_configure(sim)


def run(args: argparse.Namespace) -> dict[str, Any] | None:
    if args.what == "simulate-stage":
        from camcmm.api import ParameterError

        from .simulator import ConfigError, Simulator

        try:  # every option is checked before anything is opened or printed
            sim = Simulator(args)
        except ConfigError as exc:
            raise ParameterError(str(exc)) from None
        try:
            sim.announce()
            sim.serve_forever()
        finally:
            sim.close()
        return None
    from camcmm.api import default_host

    host = default_host()
    devices = [
        {
            "id": s.id,
            "role": s.role or "",
            "name": s.name,
            "status": s.status,
            "simulated": bool(s.simulated),
            "summary": s.summary,
        }
        for s in host.all()
        if s.kind == "device"
    ]
    out: dict[str, Any] = {"devices": devices}
    if args.ports:
        from serial.tools import list_ports

        out["ports"] = [
            {"port": p.device, "description": p.description, "hwid": p.hwid}
            for p in sorted(list_ports.comports(), key=lambda p: p.device)
        ]
    return out


def text(result: dict[str, Any]) -> str:
    lines = [
        f"{d['id']:34s} {d['role']:14s} {'(sim) ' if d['simulated'] else ''}{d['name']}"
        + ("" if d["status"] == "ok" else f"  [{d['status']}]")
        for d in result["devices"]
    ]
    if "ports" in result:
        lines.append("")
        lines += [f"{p['port']:20s} {p['description']}" for p in result["ports"]] or ["no serial ports found"]
    return "\n".join(lines)
