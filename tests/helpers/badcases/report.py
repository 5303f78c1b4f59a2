"""Bad customer fields of a report (issue 28): the plan's ``report:`` mapping of ``camcmm
gdt evaluate`` and the ``--temperature`` option of ``camcmm gdt evaluate`` and ``camcmm
inspect``. Ids start with ``report-``.

A misspelt key, a value that is a list or a mapping, a temperature that is no
temperature in °C, a ``report:`` that is not a mapping: refused in one line naming the
plan file and the key (or the option), before the cloud is evaluated.
"""

from __future__ import annotations

from helpers.badcases.gdt import CLOUD, PLAN, _cloud, _plan, _set
from helpers.badinputs import Case, _sphere, _xyz_text


def _gdt(cid: str, report: object, names: tuple[str, ...], *opts: str) -> Case:
    plan = _plan(_set("report", report)) if report is not None else _plan()
    argv = ("gdt", "evaluate", PLAN, CLOUD, "--align", "none", *opts, "--json")
    return Case(f"report-{cid}", argv, {PLAN: plan, CLOUD: _cloud()}, names)


def cases() -> list[Case]:
    return [
        _gdt("misspelt-key", {"custmer": "ACME"}, ("report.custmer",)),
        _gdt("a-list-value", {"order": [1, 2]}, ("report.order",)),
        _gdt("a-mapping-value", {"operator": {"name": "x"}}, ("report.operator",)),
        _gdt("not-a-mapping", ["customer"], ("report",)),
        _gdt("temperature-absurd", {"temperature": 5000}, ("report.temperature",)),
        _gdt("temperature-nan", {"temperature": float("nan")}, ("report.temperature",)),
        _gdt("option-temperature", None, ("--temperature",), "--temperature", "-300"),
        Case(
            "report-inspect-temperature",
            ("inspect", "scan.xyz", "--nominal", "n.stl", "--temperature", "1e9"),
            {"scan.xyz": _xyz_text(_sphere(200))},  # refused before any file is looked at
            ("--temperature",),
        ),
    ]
