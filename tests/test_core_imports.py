"""The house of ``core/`` (docs/model.md, "The kernel's layout"): ``kernel/`` sits at the
bottom and imports nothing of ``core`` above it, and ``core``'s modules import each other
without a circle; nor do the modules of the whole package.  Imports are read from the
source (``ast``), those inside functions too."""
from __future__ import annotations

import ast
from pathlib import Path

import tethernet_ros
import tethernet_ros.core

CORE = Path(tethernet_ros.core.__file__).parent
PACKAGE = "tethernet_ros.core"
ROOT = Path(tethernet_ros.__file__).parent
KERNEL = PACKAGE + ".kernel"


def _module_name(path: Path, root: Path, package: str) -> str:
    parts = list(path.relative_to(root).with_suffix("").parts)
    if parts[-1] == "__init__":
        parts = parts[:-1]
    return ".".join([package] + parts)


def import_graph(root: Path = CORE, package: str = PACKAGE) -> dict[str, set[str]]:
    """Each module of ``package`` (its source under ``root``) -> the modules of it that it
    imports (anywhere in its source)."""
    files = {_module_name(p, root, package): p for p in sorted(root.rglob("*.py"))}
    graph: dict[str, set[str]] = {m: set() for m in files}
    for mod, path in files.items():
        here = mod if path.name == "__init__.py" else mod.rpartition(".")[0]
        for node in ast.walk(ast.parse(path.read_text(), str(path))):
            if isinstance(node, ast.Import):
                names = [a.name for a in node.names]
            elif isinstance(node, ast.ImportFrom):
                if node.level:
                    up = here.split(".")[:len(here.split(".")) - node.level + 1]
                    base = ".".join(up + ([node.module] if node.module else []))
                else:
                    base = node.module or ""
                names = [base] + [f"{base}.{a.name}" for a in node.names]
            else:
                continue
            graph[mod].update(n for n in names if n in files and n != mod)
    return graph


def strongly_connected(graph: dict[str, set[str]]) -> list[list[str]]:
    """Tarjan's strongly connected components (iterative)."""
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    on_stack: set[str] = set()
    out: list[list[str]] = []
    for root in sorted(graph):
        if root in index:
            continue
        work = [(root, iter(sorted(graph[root])))]
        index[root] = low[root] = len(index)
        stack.append(root)
        on_stack.add(root)
        while work:
            v, it = work[-1]
            w = next(it, None)
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
                out.append(sorted(comp))
    return out


def _in_kernel(mod: str) -> bool:
    return mod == KERNEL or mod.startswith(KERNEL + ".")


def test_the_graph_sees_the_kernels_own_imports():
    graph = import_graph()
    assert KERNEL + ".implicit" in graph[KERNEL]
    assert KERNEL + ".events" in graph[KERNEL + ".implicit"]


def test_kernel_imports_nothing_of_core_above_it():
    graph = import_graph()
    upward = {m: sorted(t for t in deps if not _in_kernel(t))
              for m, deps in graph.items() if _in_kernel(m)}
    assert {m: t for m, t in upward.items() if t} == {}


def test_core_has_no_import_cycle():
    cycles = [c for c in strongly_connected(import_graph()) if len(c) > 1]
    assert cycles == []


def test_the_package_has_no_import_cycle():
    graph = import_graph(ROOT, "tethernet_ros")
    assert "tethernet_ros.montecarlo.records" in graph["tethernet_ros.montecarlo.backends"]
    cycles = [c for c in strongly_connected(graph) if len(c) > 1]
    assert cycles == []
