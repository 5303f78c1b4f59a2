"""Architecture rules that keep the code base easy to find one's way in."""

from __future__ import annotations

import ast
import os
import re
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
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
    code = (
        "import sys, camcmm.api, camcmm.host, camcmm.io, camcmm.project, camcmm.cli.main;"
        "heavy = [m for m in ('trame', 'vtk', 'pyvista', 'open3d', 'cv2') if m in sys.modules];"
        "print(','.join(heavy))"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == "", f"importing the core loaded {out.stdout.strip()}"


def test_tasks_need_no_gui_trame_or_vtk():
    """The tasks layer (camcmm.tasks) is what the pages run: it imports nothing of the GUI,
    by name or at run time, and importing every task module loads neither trame nor VTK."""
    tasks = ROOT / "app" / "camcmm" / "tasks"
    offenders = []
    for path in tasks.rglob("*.py"):
        tree = ast.parse(path.read_text(), str(path))
        for node in ast.walk(tree):
            names = []
            if isinstance(node, ast.Import):
                names = [a.name for a in node.names]
            elif isinstance(node, ast.ImportFrom):
                names = [("." * node.level) + (node.module or "")]
            for name in names:
                if name.startswith(("camcmm.gui", "trame", "vtk", "pyvista", "..gui", ".gui")) or name == "..gui":
                    offenders.append(f"{path.relative_to(ROOT)} imports {name}")
    assert not offenders, "\n".join(offenders)
    modules = [".".join(p.relative_to(ROOT / "app").with_suffix("").parts) for p in tasks.rglob("*.py")]
    code = (
        "import importlib, sys\n"
        "for m in sys.argv[1:]:\n    importlib.import_module(m.removesuffix('.__init__'))\n"
        "print(','.join(m for m in ('trame', 'vtk', 'pyvista') if m in sys.modules))"
    )
    out = subprocess.run([sys.executable, "-c", code, *modules], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == "", f"importing camcmm.tasks loaded {out.stdout.strip()}"


def test_no_mixin_stack_under_the_pages():
    """A page is one class holding its task and parts (composition): no class under
    gui/pages/ has more than one base, and none derives from another page's part."""
    pages = ROOT / "app" / "camcmm" / "gui" / "pages"
    stacks = []
    for path in pages.rglob("*.py"):
        for node in ast.walk(ast.parse(path.read_text(), str(path))):
            if isinstance(node, ast.ClassDef) and len(node.bases) > 1:
                stacks.append(f"{path.relative_to(ROOT)}: class {node.name}({', '.join(map(ast.unparse, node.bases))})")
    assert not stacks, "\n".join(stacks)


#: In one interpreter that has loaded the third-party libraries only (importing them is
#: most of a fresh interpreter's cost, and which of them came first cannot hide a cycle
#: of ours), each module is imported in a child forked from it: a clean ``sys.modules``
#: of camcmm per module at a fraction of an interpreter start (18 s -> ~3 s).
_IMPORT_EACH = """
import importlib, os, sys, traceback
for lib in ("numpy", "scipy.linalg", "scipy.spatial", "scipy.optimize", "scipy.stats", "yaml"):
    try:
        importlib.import_module(lib)
    except ImportError:
        pass
assert not any(k == "camcmm" or k.startswith("camcmm.") for k in sys.modules)
failed = []
for m in sys.argv[1:]:
    pid = os.fork()
    if pid == 0:
        try:
            importlib.import_module(m)
        except BaseException:
            traceback.print_exc()
            os._exit(1)
        os._exit(0)
    if os.waitpid(pid, 0)[1] != 0:
        failed.append(m)
print(" ".join(failed))
sys.exit(1 if failed else 0)
"""


@pytest.mark.slow
def test_every_core_module_imports_on_its_own():
    # A module that only imports after another one is half of a circular import.
    modules = [
        ".".join(p.relative_to(ROOT / "app").with_suffix("").parts).removesuffix(".__init__")
        for p in (ROOT / "app" / "camcmm").rglob("*.py")
        if "gui" not in p.parts and p.name != "__main__.py"
    ]
    if not hasattr(os, "fork"):
        pytest.skip("needs os.fork")
    r = subprocess.run([sys.executable, "-c", _IMPORT_EACH, *modules], capture_output=True, text=True)
    assert r.returncode == 0, f"modules that do not import on their own: {r.stdout.strip()}\n{r.stderr[-3000:]}"


# -- import cycles ----------------------------------------------------------------------
def _module_paths() -> dict[str, Path]:
    mods = {}
    for base, package in ((ROOT / "app", "camcmm"), (ROOT / "plugins", "camcmm_plugins")):
        for p in (base / package).rglob("*.py"):
            parts = list(p.relative_to(base).with_suffix("").parts)
            mods[".".join(parts[:-1] if parts[-1] == "__init__" else parts)] = p
    return mods


def _import_graph() -> dict[str, set[str]]:
    """module -> the modules of ours it imports, from every import statement at any depth
    (a function-level import closes a cycle just as well, only later), relative imports
    resolved. ``from pkg import name`` counts as importing ``pkg.name`` when that is a
    module, else ``pkg``; a parent package imported implicitly is not an edge."""
    mods = _module_paths()
    graph: dict[str, set[str]] = {m: set() for m in mods}
    for m, path in mods.items():
        package = m.split(".") if path.name == "__init__.py" else m.split(".")[:-1]
        for node in ast.walk(ast.parse(path.read_text(), str(path))):
            if isinstance(node, ast.Import):
                targets = [a.name for a in node.names]
            elif isinstance(node, ast.ImportFrom):
                base = package[: len(package) - node.level + 1] if node.level else []
                mod = ".".join(base + ([node.module] if node.module else []))
                subs = [f"{mod}.{a.name}" for a in node.names if f"{mod}.{a.name}" in mods]
                targets = subs + ([mod] if len(subs) < len(node.names) else [])
            else:
                continue
            for t in targets:
                while t and t not in mods:
                    t = t.rpartition(".")[0]
                if t and t != m:
                    graph[m].add(t)
    return graph


def _cycles(graph: dict[str, set[str]]) -> list[list[str]]:
    """The strongly connected components with more than one module (Tarjan, iterative)."""
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    on_stack: set[str] = set()
    found = []
    for root in sorted(graph):
        if root in index:
            continue
        work = [(root, iter(sorted(graph[root])))]
        index[root] = low[root] = len(index)
        stack.append(root)
        on_stack.add(root)
        while work:
            v, children = work[-1]
            w = next(children, None)
            if w is not None:
                if w not in index:
                    index[w] = low[w] = len(index)
                    stack.append(w)
                    on_stack.add(w)
                    work.append((w, iter(sorted(graph[w]))))
                elif w in on_stack:
                    low[v] = min(low[v], index[w])
                continue
            work.pop()
            if work:
                low[work[-1][0]] = min(low[work[-1][0]], low[v])
            if low[v] == index[v]:
                comp = []
                while True:
                    w = stack.pop()
                    on_stack.discard(w)
                    comp.append(w)
                    if w == v:
                        break
                if len(comp) > 1:
                    found.append(sorted(comp))
    return found


def _where(cycle: list[str]) -> str:
    return "gui" if any(m == "camcmm.gui" or m.startswith("camcmm.gui.") for m in cycle) else "core"


@pytest.mark.slow
def test_the_cycle_finder_sees_function_level_and_relative_imports():
    graph = {"a": {"b"}, "b": {"c"}, "c": {"a"}, "d": {"a"}}
    assert _cycles(graph) == [["a", "b", "c"]]
    real = _import_graph()
    assert "camcmm.errors" in real["camcmm.host"]  # `from .errors import ...`
    assert "camcmm.io" in real["camcmm.host"]  # `from .io import read` inside a function


@pytest.mark.parametrize("part", ["core", "gui"])
@pytest.mark.slow
def test_no_import_cycles(part):
    # camcmm and the built-in plugins; the GUI reported apart (its pages are many small modules)
    cycles = [c for c in _cycles(_import_graph()) if _where(c) == part]
    assert not cycles, "import cycles:\n" + "\n".join(" <-> ".join(c) for c in cycles)
