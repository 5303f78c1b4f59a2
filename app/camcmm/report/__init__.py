"""Reports: one structured document rendered as self-contained HTML, PDF and JSON.

Generic — it knows no particular standard. A standard (or an inspection, or an
uncertainty budget) fills sections with paragraphs, key-value lists, tables, figures,
verdicts and warnings, records provenance and the machine-readable result, and calls
:meth:`Report.write`::

    from camcmm.report import Report, charts
    r = Report("VDI/VDE 2634-2 acceptance test", subtitle="Stereo FP", meta={"operator": "..."})
    s = r.section("Probing error form P_F")
    s.table(columns=["Position", "P_F [mm]"], rows=[[1, 0.120]], caption="Per position")
    s.figure(charts.bar_chart(["1"], [0.120], limit=0.186), caption="P_F per position")
    s.verdict("P_F", simple="pass", guarded="inconclusive", value="0.120 mm", limit="0.186 mm")
    r.provenance(software="camcmm 0.1.0", plugins=[...], inputs=[{"file": ..., "sha256": ...}])
    r.data = verify_json
    r.write("out")   # -> {"html": ..., "pdf": ..., "json": ...}

Importing this package loads neither matplotlib nor reportlab; ``charts`` imports
matplotlib when a chart is drawn, the PDF writer reportlab when a PDF is made.
"""

from __future__ import annotations

from . import charts
from .blocks import VERDICTS, jsonable
from .document import Report, Section

__all__ = ["Report", "Section", "VERDICTS", "charts", "jsonable"]
