"""The layers import only downward, read from the source of every module (STYLE.md).

Every import statement of every module of the package counts, wherever it stands (module
top, inside a function or a method); only ``if TYPE_CHECKING:`` blocks, which never run, are
left out.  Direct imports must respect each layer's rules; following the package's own
imports, so must everything a layer loads.

    core     numpy/scipy only              pinn     the only torch importer
    bags     the only rosbags/mcap importer report   core, bags, Matplotlib (no pyplot)
    nodes    the only rclpy / *_msgs importer; uses the layers below, never torch itself
    cli, pipeline, events, store, bench, progress: orchestration over core, pinn, bags, report
    fleet    many bags on a process pool or a Ray cluster: over the layers above, never rclpy

The report only renders: none of its modules loads what identifies (the PINN, the front
door and its methods) or keeps results (events, the store, the fleet).
"""

from __future__ import annotations

import ast
import subprocess
import sys
from dataclasses import dataclass
from functools import lru_cache
from pathlib import Path

import pytest

PACKAGE = Path(__file__).resolve().parents[2] / "pier_monitor"
ROS = ("rclpy", "rcl_interfaces", "builtin_interfaces", "std_msgs", "sensor_msgs",
       "diagnostic_msgs", "visualization_msgs", "geometry_msgs", "tf2_msgs", "pier_monitor_msgs")
BAGS = ("rosbags", "mcap", "mcap_ros2")
TOP = ("pier_monitor.cli", "pier_monitor.pipeline", "pier_monitor.events", "pier_monitor.bench",
       "pier_monitor.bench_live", "pier_monitor.bench_heldout", "pier_monitor.bench_fiber",
       "pier_monitor.bench_greybox", "pier_monitor.store",
       "pier_monitor.training_progress")

#: Third-party packages a layer may import directly (by top-level name).
ALLOWED_THIRD_PARTY = {
    # openseespy: only core.synthetic.fiber, imported lazily (the optional extra "fiber")
    "core": {"numpy", "scipy", "yaml", "numba", "openseespy"},
    "pinn": {"numpy", "torch"},
    "bags": {"numpy", "yaml", *BAGS},
    "report": {"numpy", "matplotlib"},
    "nodes": {"numpy", "yaml", *ROS},
    "top": {"numpy", "tqdm", "yaml"},
    "fleet": {"numpy", "tqdm", "ray"},
    "root": set(),
}
#: Layers of the package a layer may import.
ALLOWED_LAYERS = {
    "core": {"core", "root"},
    "pinn": {"core", "pinn", "root"},
    "bags": {"core", "bags", "root"},
    "report": {"core", "bags", "report", "root"},
    "nodes": {"core", "bags", "report", "pinn", "top", "fleet", "nodes", "root"},
    "top": {"core", "bags", "report", "pinn", "top", "fleet", "root"},
    "fleet": {"core", "bags", "report", "pinn", "top", "fleet", "root"},
    "root": {"root"},
}
#: What a layer must never load, following the package's own imports.
NEVER_LOADED = {
    "core": {"torch", "matplotlib", *ROS, *BAGS},
    "pinn": {"matplotlib", *ROS, *BAGS},
    "bags": {"torch", "matplotlib", *ROS},
    "report": {"torch", *ROS},
    "top": set(ROS),
    "fleet": set(ROS),
}


@dataclass(frozen=True)
class Import:
    """One imported module of a source file."""

    module: str
    line: int
    in_function: bool
    comment: str


def module_name(path: Path) -> str:
    rel = path.relative_to(PACKAGE.parent).with_suffix("")
    parts = rel.parts[:-1] if rel.name == "__init__" else rel.parts
    return ".".join(parts)


@lru_cache(maxsize=None)
def modules() -> dict[str, Path]:
    return {module_name(p): p for p in sorted(PACKAGE.rglob("*.py"))}


def layer(module: str) -> str:
    parts = module.split(".")
    if len(parts) == 1:
        return "root"
    if parts[1] in ("core", "pinn", "bags", "report", "nodes", "fleet"):
        return parts[1]
    return "top" if module in TOP else "root"


def _is_type_checking(node: ast.If) -> bool:
    test = node.test
    return (isinstance(test, ast.Name) and test.id == "TYPE_CHECKING") or (
        isinstance(test, ast.Attribute) and test.attr == "TYPE_CHECKING")


def parse_imports(text: str, module: str, is_package: bool = False) -> tuple[Import, ...]:
    """Modules imported by the source ``text`` of ``module``, relative imports resolved."""
    lines = text.splitlines()
    package = module if is_package else module.rpartition(".")[0]
    found: list[Import] = []

    def visit(node: ast.AST, in_function: bool) -> None:
        for child in ast.iter_child_nodes(node):
            if isinstance(child, ast.If) and _is_type_checking(child):
                for sub in child.orelse:
                    visit(sub, in_function)
                continue
            inner = in_function or isinstance(child, (ast.FunctionDef, ast.AsyncFunctionDef,
                                                      ast.Lambda))
            line = lines[child.lineno - 1] if hasattr(child, "lineno") else ""
            comment = line.partition("#")[2]
            if isinstance(child, ast.Import):
                found.extend(Import(a.name, child.lineno, in_function, comment)
                             for a in child.names)
            elif isinstance(child, ast.ImportFrom):
                base = child.module or ""
                if child.level:
                    anchor = package.split(".")
                    anchor = anchor[:len(anchor) - (child.level - 1)]
                    base = ".".join([*anchor, base] if base else anchor)
                found.append(Import(base, child.lineno, in_function, comment))
                for alias in child.names:  # ``from package import submodule``
                    if f"{base}.{alias.name}" in modules():
                        found.append(Import(f"{base}.{alias.name}", child.lineno, in_function,
                                            comment))
            visit(child, inner)

    visit(ast.parse(text), False)
    return tuple(found)


@lru_cache(maxsize=None)
def imports_of(module: str) -> tuple[Import, ...]:
    """Modules imported by a module of the package."""
    path = modules()[module]
    return parse_imports(path.read_text(), module, path.name == "__init__.py")


def project_target(name: str) -> str | None:
    """The package module an import loads (None: not the package's)."""
    if name != "pier_monitor" and not name.startswith("pier_monitor."):
        return None
    while name not in modules():
        name = name.rpartition(".")[0]
    return name


def loaded_by(module: str) -> tuple[set[str], set[str]]:
    """Package modules and third-party top-level names loaded by importing ``module``."""
    seen: set[str] = set()
    third: set[str] = set()
    todo = [module]
    while todo:
        m = todo.pop()
        if m in seen:
            continue
        seen.add(m)
        parts = m.split(".")
        todo.extend(".".join(parts[:i]) for i in range(1, len(parts)))  # parent packages
        for imp in imports_of(m):
            target = project_target(imp.module)
            if target is not None:
                todo.append(target)
            else:
                third.add(imp.module.split(".")[0])
    return seen, third


STDLIB = set(sys.stdlib_module_names)


def violations(module: str, imports: tuple[Import, ...]) -> list[str]:
    """What breaks the direct-import rules of ``module``'s layer, one line each."""
    own = layer(module)
    bad = []
    for imp in imports:
        target = project_target(imp.module)
        where = f"{module}:{imp.line}"
        if target is not None:
            if layer(target) not in ALLOWED_LAYERS[own]:
                bad.append(f"{where}: {own} imports {target} ({layer(target)})")
            if imp.in_function:
                bad.append(f"{where}: {target} imported inside a function (a hidden "
                           "dependency: import it at the module top)")
            continue
        top = imp.module.split(".")[0]
        if imp.module.startswith("matplotlib.pyplot"):
            bad.append(f"{where}: matplotlib.pyplot (global state; use the object API)")
        if top not in STDLIB and top not in ALLOWED_THIRD_PARTY[own]:
            bad.append(f"{where}: {own} imports {top}")
        if imp.in_function and "optional heavy dependency" not in imp.comment:
            bad.append(f"{where}: {imp.module} imported inside a function; import it at the "
                       "module top, or name it '# optional heavy dependency'")
    return bad


@pytest.mark.parametrize("module", sorted(modules()))
def test_direct_imports_respect_the_layer(module: str) -> None:
    bad = violations(module, imports_of(module))
    assert not bad, "\n".join(bad)


@pytest.mark.parametrize("module", sorted(m for m in modules() if layer(m) in NEVER_LOADED))
def test_what_a_layer_loads_stays_within_it(module: str) -> None:
    _, third = loaded_by(module)
    forbidden = sorted(third & NEVER_LOADED[layer(module)])
    assert not forbidden, f"importing {module} loads {forbidden}"


#: What identifies or keeps results: the report renders results it is given, so none of its
#: modules may load these (following the package's own imports), by name or package prefix.
IDENTIFYING = ("pier_monitor.pinn", "pier_monitor.core.identify.methods",
               "pier_monitor.core.identify.equation_error", "pier_monitor.core.identify.field",
               "pier_monitor.core.identify.ensemble", "pier_monitor.core.identify.families",
               "pier_monitor.core.identify.selfcheck", "pier_monitor.events",
               "pier_monitor.pipeline", "pier_monitor.store", "pier_monitor.fleet")


def _is_identifying(module: str) -> bool:
    return any(module == name or module.startswith(name + ".") for name in IDENTIFYING)


@pytest.mark.parametrize("module", sorted(m for m in modules() if layer(m) == "report"))
def test_the_report_only_renders(module: str) -> None:
    direct = sorted({t for i in imports_of(module)
                     if (t := project_target(i.module)) and _is_identifying(t)})
    assert not direct, f"{module} imports {direct}"
    project, _ = loaded_by(module)
    loaded = sorted(m for m in project if _is_identifying(m))
    assert not loaded, f"importing {module} loads {loaded}"


def test_the_report_scan_sees_an_identifying_import() -> None:
    """The check above is not vacuous: a report module importing the front door, the PINN
    or the store is caught, a result type is not."""
    source = ("from pier_monitor.core.identify.methods import identify\n"
              "from pier_monitor.core.identify.damage import IdentificationResult\n"
              "import pier_monitor.pinn.trainer\n"
              "from pier_monitor import store\n")
    found = parse_imports(source, "pier_monitor.report.figures")
    hits = sorted({t for i in found if (t := project_target(i.module)) and _is_identifying(t)})
    assert hits == ["pier_monitor.core.identify.methods", "pier_monitor.pinn.trainer",
                    "pier_monitor.store"]


def test_the_ingest_node_does_not_load_the_pinn() -> None:
    project, third = loaded_by("pier_monitor.nodes.ingest_node")
    assert "torch" not in third and "pier_monitor.pinn" not in project


def test_an_import_inside_a_method_is_seen_and_type_checking_blocks_are_not() -> None:
    """A lazy ``import torch`` in a method of core would not escape the checks above."""
    source = ("from typing import TYPE_CHECKING\n"
              "if TYPE_CHECKING:\n    import rclpy\n"
              "class A:\n    def f(self):\n        import torch\n        return torch\n")
    found = parse_imports(source, "pier_monitor.core.model.units")
    assert [(i.module, i.in_function) for i in found] == [("typing", False), ("torch", True)]
    bad = violations("pier_monitor.core.model.units", found)
    assert any("core imports torch" in b for b in bad)
    assert any("torch imported inside a function" in b for b in bad)


#: What importing a node's module must leave out of ``sys.modules`` (measured in a fresh
#: interpreter, not read from the source): the ingest node never needs the report's
#: figures, torch or the bag files; the identifier node loads torch only when it trains.
NODE_NEVER_LOADS = {
    "pier_monitor.nodes.ingest_node": ("torch", "matplotlib", "mcap"),
    "pier_monitor.nodes.identifier_node": ("torch",),
}


def _loaded_in_fresh_interpreter(code: str, names: tuple[str, ...]) -> list[str]:
    """Run ``code`` in a new interpreter and return which of ``names`` it loaded."""
    probe = f"{code}\nimport sys\nprint(' '.join(n for n in {names!r} if n in sys.modules))"
    out = subprocess.run([sys.executable, "-c", probe], capture_output=True, text=True,
                         timeout=300, check=True)
    return out.stdout.split()


@pytest.mark.parametrize("module", sorted(NODE_NEVER_LOADS))
def test_a_node_module_loads_only_what_it_uses(module: str) -> None:
    loaded = _loaded_in_fresh_interpreter(f"import {module}", NODE_NEVER_LOADS[module])
    assert not loaded, f"importing {module} loads {loaded}"


def test_a_field_identification_never_loads_torch_or_resolves_a_device() -> None:
    """``--method field --device cuda`` on a machine without a GPU: the numpy method never
    asks for the device, so it succeeds, and torch stays unloaded."""
    code = ("from pier_monitor.core.identify.methods import IdentifySettings, identify\n"
            "from pier_monitor.core.synthetic.reference import paper_case_window\n"
            "window, _, _ = paper_case_window(seed=0, window_s=(30.0, 36.0))\n"
            "run = identify(window, IdentifySettings(method='field', device='cuda'))\n"
            "assert run.result.success and run.result.device == 'cpu', run.result.message\n")
    assert _loaded_in_fresh_interpreter(code, ("torch",)) == []
