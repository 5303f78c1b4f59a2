"""Architecture rules that keep the code base easy to find one's way in."""

from __future__ import annotations

import ast
import re
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
BUILTINS = ROOT / "plugins" / "camcmm_plugins"


def _imports(path: Path):
    for node in ast.walk(ast.parse(path.read_text(), str(path))):
        if isinstance(node, ast.Import):
            yield from (a.name for a in node.names)
        elif isinstance(node, ast.ImportFrom) and node.level == 0 and node.module:
            yield node.module


def test_builtin_plugins_use_only_the_public_api():
    offenders = []
    for path in BUILTINS.rglob("*.py"):
        package = path.relative_to(BUILTINS).parts[0]
        for name in _imports(path):
            if name.startswith("camcmm.") and name != "camcmm.api":
                offenders.append(f"{path.relative_to(ROOT)} imports {name}")
            if name.startswith("camcmm_plugins.") and name.split(".")[1] != package:
                offenders.append(f"{path.relative_to(ROOT)} imports another plugin: {name}")
        # an import by name at run time is an import all the same
        for m in re.finditer(r"import_module\(\s*[\"'](camcmm[\w.]*)", path.read_text()):
            if m.group(1) != "camcmm.api":
                offenders.append(f"{path.relative_to(ROOT)} imports {m.group(1)} at run time")
    assert not offenders, "\n".join(offenders)


def test_core_and_api_import_without_gui_or_open3d():
    code = ("import sys, camcmm.api, camcmm.host, camcmm.io, camcmm.project, camcmm.cli.main;"
            "heavy = [m for m in ('trame', 'vtk', 'pyvista', 'open3d', 'cv2') if m in sys.modules];"
            "print(','.join(heavy))")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == "", f"importing the core loaded {out.stdout.strip()}"


def test_every_core_module_imports_on_its_own():
    # A module that only imports after another one is half of a circular import.
    modules = [".".join(p.relative_to(ROOT / "app").with_suffix("").parts)
               for p in (ROOT / "app" / "camcmm").rglob("*.py")
               if "gui" not in p.parts and p.name != "__main__.py"]
    code = "import importlib, sys\nfor m in sys.argv[1:]:\n    importlib.import_module(m.removesuffix('.__init__'))"
    for m in modules:
        subprocess.run([sys.executable, "-c", code, m], check=True, capture_output=True)
