"""Hold the repository to its layout rules (docs/layout.md); run by ``make lint``.

* Modules of every package folder (``pipeline/``, ``library/``, ``runtime/``, ``control/``,
  ``sim/``, ``proving/``) at most 250 lines, functions at most 60.
* Imports follow the data path: ``library/`` imports none of the others; ``runtime/`` only
  ``library``; ``control/`` (the controller a robot runs) only ``library`` and ``runtime``, never
  the proving ground, the twin or the pipeline; ``sim/`` only ``library`` and ``runtime``;
  ``proving/`` (the proving ground) anything but ``pipeline``; ``pipeline/ocp/`` (the engine, with
  its compile cache's trust) no robot subpackage, nor the build, the views or the CLI;
  ``pipeline/build/`` neither the views nor the CLI (it reports through callbacks).
* The library file's names stay in ``library/``: no ``/model`` attribute or dataset name of the
  records (:mod:`skatelib.library.model`) and no entry or root attribute name of the schema as a
  literal key (``x["name"]``, ``x.get("name")``, ``{"name": ...}``) in another package (read the
  record, or use the schema's constant).
* No import cycle among skatelib's modules, counting imports inside functions and under
  ``TYPE_CHECKING`` (a cycle hidden by a local import is still a cycle).
* ``library/`` and ``runtime/`` (what a robot installs) import only the standard library, numpy,
  h5py and skatelib; ``control/`` besides them only pinocchio, scipy, its QP solvers and
  threadpoolctl (the ``[control]`` extra).

Usage: ``python tools/check_layout.py [ROOT]``; exit 1 listing every breach.
"""

from __future__ import annotations

import ast
import sys
from pathlib import Path

MAX_MODULE_LINES = 250
MAX_FUNCTION_LINES = 60
PACKAGES = ("pipeline", "library", "runtime", "control", "sim", "proving")
FORBIDDEN = {  # folder -> imported packages it must not use
    "library": ("skatelib.pipeline", "skatelib.runtime", "skatelib.control", "skatelib.sim", "skatelib.proving"),
    "runtime": ("skatelib.pipeline", "skatelib.control", "skatelib.sim", "skatelib.proving"),
    "control": ("skatelib.pipeline", "skatelib.sim", "skatelib.proving"),
    "sim": ("skatelib.pipeline", "skatelib.control", "skatelib.proving"),
    "proving": ("skatelib.pipeline",),
    "pipeline/build": ("skatelib.pipeline.views", "skatelib.pipeline.cli"),
    "pipeline/ocp": ("skatelib.pipeline.quadruped", "skatelib.pipeline.humanoid", "skatelib.pipeline.build",
                     "skatelib.pipeline.views", "skatelib.pipeline.cli"),
}
ONBOARD_ALLOWED = {*sys.stdlib_module_names, "numpy", "h5py", "skatelib"}
# What a robot installs, and the third-party packages each may import besides.
ONBOARD = {
    "library": ONBOARD_ALLOWED,
    "runtime": ONBOARD_ALLOWED,
    "control": {*ONBOARD_ALLOWED, "pinocchio", "scipy", "daqp", "proxsuite", "osqp", "threadpoolctl"},
}


def file_names() -> frozenset[str]:
    """The names of the library file that only ``library/`` spells out: the ``/model`` records'
    attributes and datasets, and the schema's attribute names of more than one word."""
    from skatelib.library import model_io, schema

    attrs = {v for k, v in vars(schema).items() if k.startswith("A_") and isinstance(v, str) and "_" in v}
    return frozenset({*(n for n in model_io.attribute_names() if "_" in n), *attrs})


def _literals(tree: ast.AST, names: frozenset[str]) -> list[tuple[int, str]]:
    """The file's names used as keys: ``x["name"]``, ``x.get("name", ...)`` and ``{"name": ...}``."""
    keys: list[ast.expr] = []
    for n in ast.walk(tree):
        if isinstance(n, ast.Subscript):
            keys.append(n.slice)
        elif isinstance(n, ast.Call) and isinstance(n.func, ast.Attribute) and n.func.attr == "get" and n.args:
            keys.append(n.args[0])
        elif isinstance(n, ast.Dict):
            keys += [k for k in n.keys if k is not None]
    return [(k.lineno, k.value) for k in keys if isinstance(k, ast.Constant) and k.value in names]


def _imports(tree: ast.AST) -> list[tuple[int, str]]:
    out = []
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            out += [(node.lineno, a.name) for a in node.names]
        elif isinstance(node, ast.ImportFrom) and node.module:
            out.append((node.lineno, node.module))
    return out


def _module_name(rel: str) -> str:
    parts = rel.removesuffix(".py").split("/")
    return ".".join(["skatelib", *(parts[:-1] if parts[-1] == "__init__" else parts)])


def _edges(modules: dict[str, ast.AST]) -> dict[str, set[str]]:
    """Each module's skatelib imports (anywhere in it), resolved to the modules of the tree."""
    def resolve(name: str) -> str:
        while name and name not in modules:
            name = name.rsplit(".", 1)[0] if "." in name else ""
        return name

    edges: dict[str, set[str]] = {m: set() for m in modules}
    for m, tree in modules.items():
        for node in ast.walk(tree):
            if isinstance(node, ast.Import):
                names = [a.name for a in node.names]
            elif isinstance(node, ast.ImportFrom) and node.module:
                names = [f"{node.module}.{a.name}" for a in node.names]
            else:
                continue
            edges[m] |= {r for n in names if n.startswith("skatelib.") and (r := resolve(n)) and r != m}
    return edges


def cycles(modules: dict[str, ast.AST]) -> list[list[str]]:
    """The import cycles (strongly connected components of more than one module), each sorted."""
    edges = _edges(modules)
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    found: list[list[str]] = []
    on_stack: set[str] = set()

    def visit(v: str) -> None:
        index[v] = low[v] = len(index)
        stack.append(v)
        on_stack.add(v)
        for w in edges[v]:
            if w not in index:
                visit(w)
                low[v] = min(low[v], low[w])
            elif w in on_stack:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            component = []
            while (w := stack.pop()) != v:
                on_stack.discard(w)
                component.append(w)
            on_stack.discard(v)
            if component:
                found.append(sorted([v, *component]))

    for v in modules:
        if v not in index:
            visit(v)
    return found


def _sizes(path: Path, rel: str, tree: ast.AST, n_lines: int) -> list[str]:
    found = []
    if n_lines > MAX_MODULE_LINES:
        found.append(f"{rel}: {n_lines} lines (at most {MAX_MODULE_LINES}); split it by concept")
    for node in ast.walk(tree):
        if isinstance(node, ast.FunctionDef | ast.AsyncFunctionDef):
            length = (node.end_lineno or node.lineno) - node.lineno + 1
            if length > MAX_FUNCTION_LINES:
                found.append(f"{rel}:{node.lineno}: function {node.name} has {length} lines "
                             f"(at most {MAX_FUNCTION_LINES})")
    return found


def problems(root: Path) -> list[str]:
    """Every breach of the layout rules under ``root`` (a checkout), one line each."""
    found: list[str] = []
    names = file_names()
    paths = [p for top in PACKAGES for p in sorted((root / top).rglob("*.py"))]
    modules: dict[str, ast.AST] = {}
    for path in paths:
        rel = path.relative_to(root).as_posix()
        text = path.read_text()
        tree = modules[_module_name(rel)] = ast.parse(text, filename=rel)
        found += _sizes(path, rel, tree, len(text.splitlines()))
        top = rel.split("/")[0]
        if top != "library":
            found += [f"{rel}:{line}: the library file's name {name!r} as a literal (read the record of "
                      "skatelib.library.model, or use the constant of skatelib.library.schema)"
                      for line, name in _literals(tree, names)]
        if top in ONBOARD:
            found += [f"{rel}:{line}: imports {name} ({top}/ is installed on the robot without it)"
                      for line, name in _imports(tree) if name.split(".")[0] not in ONBOARD[top]]
        for folder, banned in FORBIDDEN.items():
            if rel.startswith(folder + "/"):
                found += [f"{rel}:{line}: imports {name} ({folder}/ must not)"
                          for line, name in _imports(tree) if name.startswith(banned)]
    found += [f"import cycle: {' -> '.join(c)} (move what they share into a module of its own)"
              for c in cycles(modules)]
    return found


def main() -> None:
    root = Path(sys.argv[1]) if len(sys.argv) > 1 else Path(__file__).resolve().parents[1]
    found = problems(root)
    for line in found:
        print(line)
    if found:
        sys.exit(1)
    print(f"layout ok: modules <= {MAX_MODULE_LINES} lines, functions <= {MAX_FUNCTION_LINES}, "
          "imports follow the data path, no import cycle")


if __name__ == "__main__":
    main()
