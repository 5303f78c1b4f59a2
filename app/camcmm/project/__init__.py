"""The project store: one folder per measuring campaign.

A project is a folder holding ``project.sqlite`` (what was measured and computed, with
provenance) and ``data/<2 hex>/<sha256><ext>`` content-addressed files the database
refers to. Design principle: *nothing is lost* — every write is a transaction, data
files are durable before any row names them, so killing the process at any moment
leaves every completed result readable.

>>> from camcmm.project import Project
>>> with Project.open_or_create("run42") as p:           # doctest: +SKIP
...     h = p.add_file("sphere.ply")
...     mid = p.add_measurement("sphere 1", h)
...     rid = p.add_result(host.run("fit.sphere", {"cloud": p.load_measurement(mid)}),
...                        measurement_ids=[mid])
"""

from __future__ import annotations

from ..errors import ProjectError
from .schema import MIGRATIONS, SCHEMA_VERSION
from .store import DB_NAME, Project

__all__ = ["DB_NAME", "MIGRATIONS", "Project", "ProjectError", "SCHEMA_VERSION"]
