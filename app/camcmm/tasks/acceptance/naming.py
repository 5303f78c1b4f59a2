"""What a person reads about an acceptance test: its name (standard, measuring system,
when it started), its verdict in words, and a stored result's row in the project's
results list.

Twenty-three rows "vdi2634-2" with ISO time stamps told an operator nothing; a row is
named by what the result is (the test and the position, or the finished test's report),
the measuring system, the local date and the verdict. Only the words change: the stored
keys (``verdict``, ``verdict_guarded``, the result's ``plugin`` and ``label``) stay as
they are (contracts)."""

from __future__ import annotations

import re
from datetime import UTC, datetime
from typing import Any

from camcmm.conformity import verdict_words

#: The two verdicts of a test, as labels (the keys ``verdict``/``verdict_guarded``).
VERDICT_LABELS = {
    "verdict": "Verdict",
    "verdict_guarded": "Verdict with the test uncertainty (guarded, ISO 14253-1)",
}


def verdict_text(verdict: Any) -> str:
    """``"pass"`` -> ``"passed"``; a missing verdict is ``"incomplete"``
    (:func:`camcmm.conformity.verdict_words`)."""
    return verdict_words(verdict)


def local_time(stamp: Any) -> str:
    """An ISO time stamp (UTC as the store writes it) as the server's local date and time,
    to the minute: ``"29 Nov 2026, 21:30"``; "" for none, the text itself if unreadable."""
    text = str(stamp or "").strip()
    if not text:
        return ""
    try:
        t = datetime.fromisoformat(text.replace("Z", "+00:00"))
    except ValueError:
        return text
    if t.tzinfo is None:
        t = t.replace(tzinfo=UTC)
    t = t.astimezone()
    return f"{t.day} {t:%b %Y, %H:%M}"


def describe_test(state: dict[str, Any] | None, standard_title: str = "") -> str:
    """A test as a person names it: ``"VDI/VDE 2634 part 2 — Stereo FP, started 29 Nov
    2026, 21:30"`` (the standard's title, the measuring system, when it was set up)."""
    st = state or {}
    plan = st.get("plan") if isinstance(st.get("plan"), dict) else {}
    system = str(((plan or {}).get("system") or {}).get("name") or st.get("system") or "").strip()
    when = local_time(st.get("created"))
    text = standard_title or str(st.get("standard") or "acceptance test")
    if system:
        text += f" — {system}"
    return text + (f", started {when}" if when else "")


def status_text(state: dict[str, Any] | None, complete: bool = False) -> str:
    """Where the test stands, in words: finished with its verdicts, every position
    measured without a report, or running."""
    st = state or {}
    if st.get("summary_result") is not None:
        guarded = st.get("verdict_guarded")
        extra = f"; {verdict_text(guarded)} with the test uncertainty" if guarded else ""
        return f"finished: {verdict_text(st.get('verdict'))}{extra} (report: result #{st['summary_result']})"
    if complete:
        return "every position measured, no report yet"
    return "running"


def result_title(record: dict[str, Any], standard_title: str = "") -> tuple[str, str]:
    """(title, subtitle) of a standard plugin's stored result in the results list.

    The finished test's summary (outputs with a ``verdict``):
    ``("Acceptance test VDI/VDE 2634 part 2: passed", "guarded: passed · 29 Nov 2026, 21:30 ·
    Stereo FP")``; one position's evaluation: ``("VDI/VDE 2634 part 2: sphere-03
    (sphere)", "Stereo FP · 29 Nov 2026, 21:30")`` (the system from the record's label,
    ``"<plugin> <position> · <system>"``, as :func:`evaluation_label` writes it)."""
    outputs = record.get("outputs") if isinstance(record.get("outputs"), dict) else {}
    out: dict[str, Any] = outputs or {}
    short = re.sub(r"\s*\([^()]*\)$", "", standard_title).strip()
    title = str(out.get("standard_name") or short or record.get("plugin") or "")
    when = local_time(record.get("finished") or record.get("created"))
    label = str(record.get("label") or "")
    rest = label.split(" ", 1)[1] if " " in label else ""
    position, _, system = rest.partition(" · ")
    if "verdict" in out:  # the verdict in the title: a narrow list cuts the subtitle's end
        system = str((out.get("system") or {}).get("name") or "") if isinstance(out.get("system"), dict) else ""
        guarded = f"guarded: {verdict_text(out.get('verdict_guarded'))}" if out.get("verdict_guarded") else ""
        return (
            f"Acceptance test {title}: {verdict_text(out.get('verdict'))}",
            " · ".join(x for x in (guarded, when, system) if x),
        )
    position = str(out.get("position") or position)
    test = str(out.get("test") or "").replace("_", " ")
    what = f"{position} ({test})" if position and test else position or test or "a measurement"
    rep = out.get("repeat")
    if isinstance(rep, int) and rep > 1:
        what += f", repeat {rep}"
    failed = "failed to evaluate" if out.get("error") else ""
    return f"{title}: {what}", " · ".join(x for x in (system, when, failed) if x)


def evaluation_label(plugin: str, position: str, system: str) -> str:
    """The stored label of one position's evaluation: ``"<plugin> <position> · <system>"``
    (read back by :func:`result_title`)."""
    return f"{plugin} {position}" + (f" · {system}" if system else "")


def result_row(record: dict[str, Any], host: Any = None) -> dict[str, str]:
    """A stored result as a row of the project's results list: ``{id, plugin, time,
    title, subtitle}``. A standard plugin's result is named by :func:`result_title`;
    another plugin's by its name in words (the host's manifest) and the local date.
    ``plugin`` and ``time`` (ISO) stay for callers that read them."""
    d = record if isinstance(record, dict) else {}
    pid = str(d.get("plugin", d.get("plugin_id", "")))
    stamp = str(d.get("finished", d.get("created", "")) or "")
    spec = None
    try:
        spec = host.get(pid) if host is not None and pid else None
    except Exception:  # a plugin no longer installed: its id is all there is
        spec = None
    name = str(getattr(spec, "name", "") or pid)
    if getattr(spec, "kind", "") == "standard":
        title, subtitle = result_title(d, name)
    else:
        label = str(d.get("label") or "")
        title = name + (f": {label}" if label and label != pid and not label.startswith(pid + " ") else "")
        subtitle = local_time(stamp)
    return {"id": str(d.get("id", "")), "plugin": pid, "time": stamp, "title": title, "subtitle": subtitle}
