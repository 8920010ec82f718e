"""The package's layers: every import of an odms_data module points down, never up or sideways,
no modules import each other in a loop, nothing imports the package root, and importing the root
(or asking for help) stays light."""

from __future__ import annotations

import ast
import subprocess
import sys
from pathlib import Path

import odms_data

PACKAGE = Path(odms_data.__file__).resolve().parent

# the rank of each top-level module and folder; a module may import lower ranks and its own folder
LAYERS = {
    "_version": 0, "errors": 0,
    "interrupts": 1, "extras": 1, "user_cache": 1, "inputs": 1,
    "safe_json": 2, "protocol": 2, "resources": 2, "shown_text": 2, "parallel": 2, "pickles": 2,
    "urls": 2, "dask_runner": 2.5,  # beside parallel.py, whose ordered map it uses
    "outputs": 3,
    "store": 4,
    "simulate": 5, "importers": 5, "evaluation": 5, "publish": 5,
    "loaders": 6,
    "network": 7,
    "cli": 8,
}
HEAVY = ("cv2", "pandas", "zarr", "h5py", "jsonschema", "matplotlib", "PIL", "torch", "tensorflow", "jax",
         "grain", "dask")


def _imports(path: Path, text: str | None = None) -> list[tuple[int, str]]:
    """(line, absolute module) of every odms_data import in the module at `path` (its text, or
    `text`), lazy ones included."""
    parts = list(path.relative_to(PACKAGE.parent).with_suffix("").parts)
    package = parts[:-1]  # the package a relative import starts from (an __init__'s own)
    out = []
    for node in ast.walk(ast.parse(path.read_text() if text is None else text, str(path))):
        if isinstance(node, ast.ImportFrom):
            base = package[: len(package) - node.level + 1] if node.level else []
            module = ".".join(base + ([node.module] if node.module else []))
            if node.module is None:  # from . import x: x may be a module
                out += [(node.lineno, f"{module}.{a.name}") for a in node.names]
            else:
                out.append((node.lineno, module))
        elif isinstance(node, ast.Import):
            out += [(node.lineno, a.name) for a in node.names]
    return [(line, m) for line, m in out if m == "odms_data" or m.startswith("odms_data.")]


def _layer(module: str) -> str:
    return module.split(".")[1]


def _violation(source: str, target: str) -> str | None:
    """Why `source` may not import `target` (absolute module names), or None."""
    if target == "odms_data" or target.startswith("odms_data.__init__"):
        return "imports the package root"
    a, b = _layer(source), _layer(target)
    if a == b and (PACKAGE / a).is_dir():
        return None  # the same folder
    if LAYERS.get(b, 99) < LAYERS[a]:
        return None
    return f"{source} (layer {LAYERS[a]}) imports {target} (layer {LAYERS.get(b, '?')})"


def test_every_import_points_down():
    problems = []
    for path in sorted(PACKAGE.rglob("*.py")):
        source = path.relative_to(PACKAGE.parent).with_suffix("").as_posix().replace("/", ".")
        if source == "odms_data.__init__":
            continue  # the lazy public face names every layer
        if _layer(source) not in LAYERS:
            problems.append(f"{source}: its layer '{_layer(source)}' is not in tests/test_layering.py")
            continue
        for line, target in _imports(path):
            why = _violation(source, target)
            if why:
                problems.append(f"{path.relative_to(PACKAGE.parent)}:{line}: {why}")
    assert not problems, "\n".join(problems)


def _module(path: Path) -> str:
    dotted = path.relative_to(PACKAGE.parent).with_suffix("").as_posix().replace("/", ".")
    return dotted.removesuffix(".__init__")


def _graph() -> dict[str, set[str]]:
    """module -> the modules it imports (lazy and type-checking ones included; `from pkg import
    name` counts as importing pkg.name when that is a module, else pkg)."""
    modules = {_module(p): p for p in PACKAGE.rglob("*.py")}

    def known(target: str) -> str:
        while target not in modules:
            target = target.rpartition(".")[0]
        return target

    return {m: {known(t) for _, t in _imports(p)} - {m} for m, p in modules.items()}


def _loops(graph: dict[str, set[str]]) -> list[list[str]]:
    """The loops of `graph`: one list of modules each (a module on a loop, then the path back)."""
    loops, done = [], set()
    for start in sorted(graph):
        stack, seen = [(start, [start])], {start}
        while stack:
            m, path = stack.pop()
            for t in sorted(graph.get(m, ())):
                if t == start:
                    loops.append(path)
                elif t not in seen and t not in done:
                    seen.add(t)
                    stack.append((t, [*path, t]))
        done.add(start)
    return loops


def test_no_modules_import_each_other_in_a_loop():
    loops = _loops(_graph())
    assert not loops, "\n".join(" -> ".join([*loop, loop[0]]) for loop in loops)


def test_the_loop_check_sees_a_loop():
    assert _loops({"a": {"b"}, "b": {"c"}, "c": {"a"}, "d": {"a"}}) == [["a", "b", "c"]]
    assert _loops({"a": {"b"}, "b": set()}) == []
    graph = _graph()
    assert "odms_data.store.format" in graph["odms_data.store.reader"]


def test_the_layering_check_sees_relative_lazy_upward_and_sideways_imports():
    code = "import os\ndef f():\n    from ..loaders import sources\n    from . import masks\n"
    found = {m for _, m in _imports(PACKAGE / "store" / "probe.py", code + "    import odms_data\n")}
    assert found == {"odms_data.loaders", "odms_data.store.masks", "odms_data"}
    cli = {m for _, m in _imports(PACKAGE / "cli" / "__init__.py")}
    assert {"odms_data._version", "odms_data.errors"} <= cli
    assert _violation("odms_data.store.reader", "odms_data.loaders.sources")  # up
    assert _violation("odms_data.simulate.render", "odms_data.importers.plan")  # sideways
    assert _violation("odms_data.protocol", "odms_data.parallel")  # sideways at the root
    assert _violation("odms_data.cli.progress", "odms_data")  # the root
    assert _violation("odms_data.store.reader", "odms_data.store.masks") is None
    assert _violation("odms_data.loaders.sources", "odms_data.simulate.render") is None


def test_the_root_exports_what_it_lists_and_imports_nothing_heavy():
    assert sorted(odms_data.__all__) == sorted(["__version__", *odms_data._EXPORTS])
    libraries = ("numpy", *HEAVY)
    code = f"import sys, odms_data; print(sorted(m for m in sys.modules if m.split('.')[0] in {libraries!r}))"
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout
    assert out.strip() == "[]"
    for name in odms_data._EXPORTS:
        assert getattr(odms_data, name) is not None


def test_help_imports_no_heavy_library():
    code = ("import sys, runpy; sys.argv = ['odms-data', '--help']\n"
            "try:\n    runpy.run_module('odms_data.cli', run_name='__main__')\n"
            "except SystemExit:\n    pass\n"
            f"print(sorted(m for m in sys.modules if m.split('.')[0] in {HEAVY!r}))")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout
    assert "Commands:" in out
    assert out.strip().splitlines()[-1] == "[]"
