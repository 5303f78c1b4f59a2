"""camcmm.api is small and stable: its ``__all__`` is exactly the list docs/api.md
documents, each name exists, and the documented version is the module's."""

from __future__ import annotations

import re
from pathlib import Path

import camcmm.api as api

DOC = Path(__file__).resolve().parents[2] / "docs" / "api.md"


def _documented() -> dict[str, set[str]]:
    """{'Stable': {...}, 'Provisional': {...}}: the backticked names in the second
    column of each section's table."""
    sections: dict[str, set[str]] = {}
    current = None
    for line in DOC.read_text().splitlines():
        if line.startswith("## "):
            current = line[3:].strip()
        elif current in ("Stable", "Provisional") and line.startswith("|") and not line.startswith("|---"):
            cells = [c.strip() for c in line.strip("|").split("|")]
            if len(cells) >= 2 and cells[0] != "group":
                sections.setdefault(current, set()).update(re.findall(r"`(\w+)`", cells[1]))
    return sections


def test_all_is_exactly_the_documented_names():
    doc = _documented()
    stable, provisional = doc.get("Stable", set()), doc.get("Provisional", set())
    assert not stable & provisional, f"both stable and provisional: {sorted(stable & provisional)}"
    documented = stable | provisional
    exported = set(api.__all__)
    assert len(api.__all__) == len(exported), "a name is twice in __all__"
    assert exported == documented, (
        f"exported, not in docs/api.md: {sorted(exported - documented)}; "
        f"documented, not exported: {sorted(documented - exported)}"
    )


def test_every_exported_name_exists_and_the_version_is_documented():
    missing = [n for n in api.__all__ if not hasattr(api, n)]
    assert not missing
    major, _minor = (int(x) for x in api.API_VERSION.split("."))
    assert major >= 1
    assert f"version {api.API_VERSION}" in DOC.read_text().splitlines()[0]


def test_the_json_cleaner_and_the_clock():
    import numpy as np

    assert api.to_jsonable({"a": np.arange(2), 1: float("nan"), "t": (np.float32(1.5),)}) == {
        "a": [0, 1],
        "1": None,
        "t": [1.5],
    }
    stamp = api.utc_now(0)
    assert stamp == "1970-01-01T00:00:00.000+00:00"
