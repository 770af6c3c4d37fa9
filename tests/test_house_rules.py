"""The house rules, read off the source: data flows down, one room per concept.

The import graph of ``src/forcespace`` (every import, at module level or inside a
function; ``if TYPE_CHECKING:`` blocks are annotations, not imports) has no cycle;
no module imports another module's private (underscore) names; the library never
imports its plug-ins (the DEM adapters, the studies); the plug-ins use its public API
(no private names, not the CLI); functions stay short and numba kernels take named
state, not long lists of arrays.
"""
import ast
from pathlib import Path

import forcespace

SRC = Path(forcespace.__file__).parent
ROOT = SRC.parents[1]
PLUGINS = {"forcespace_adapters": ROOT / "adapters" / "forcespace_adapters",
           "forcespace_studies": ROOT / "studies" / "forcespace_studies"}
MAX_LINES = 80          # a function longer than this does more than one thing
MAX_KERNEL_ARGS = 12    # kernels take records of named state, not dozens of arrays


def _modules(root: Path, package: str):
    for path in sorted(root.rglob("*.py")):
        parts = list(path.relative_to(root).with_suffix("").parts)
        is_pkg = parts[-1] == "__init__"
        name = ".".join([package] + (parts[:-1] if is_pkg else parts))
        yield name, is_pkg, ast.parse(path.read_text())


def _type_checking_blocks(tree):
    return {id(n) for node in ast.walk(tree) if isinstance(node, ast.If)
            and getattr(node.test, "id", getattr(node.test, "attr", "")) == "TYPE_CHECKING"
            for child in node.body for n in ast.walk(child)}


def _imports(name: str, is_pkg: bool, tree):
    """(target module, imported name or None) of every import outside TYPE_CHECKING."""
    skip = _type_checking_blocks(tree)
    package = name if is_pkg else name.rpartition(".")[0]
    for node in ast.walk(tree):
        if id(node) in skip:
            continue
        if isinstance(node, ast.Import):
            for a in node.names:
                yield a.name, None
        elif isinstance(node, ast.ImportFrom):
            base = package.split(".")
            if node.level:
                base = base[:len(base) - node.level + 1]
                target = ".".join(base + ([node.module] if node.module else []))
            else:
                target = node.module or ""
            for a in node.names:
                yield target, a.name


def _graph(root: Path, package: str):
    modules = {name for name, _, _ in _modules(root, package)}
    edges, private = {}, []
    for name, is_pkg, tree in _modules(root, package):
        for target, imported in _imports(name, is_pkg, tree):
            full = f"{target}.{imported}" if imported else target
            dest = full if full in modules else target
            if dest not in modules:
                continue
            if imported and dest == target and imported.startswith("_") \
                    and imported != "__version__":
                private.append(f"{name} imports {target}.{imported}")
            if dest != name and dest != package:     # the package's lazy __init__ aside
                edges.setdefault(name, set()).add(dest)
    return edges, private


def _cycles(edges):
    found, state, stack = [], {}, []

    def visit(u):
        state[u] = 1
        stack.append(u)
        for v in sorted(edges.get(u, ())):
            if state.get(v) == 1:
                found.append(" -> ".join(stack[stack.index(v):] + [v]))
            elif not state.get(v):
                visit(v)
        stack.pop()
        state[u] = 2

    for u in sorted(edges):
        if not state.get(u):
            visit(u)
    return found


def test_the_library_has_no_import_cycle_and_no_private_import():
    edges, private = _graph(SRC, "forcespace")
    assert _cycles(edges) == []
    assert private == []
    assert len(edges) > 30          # the walk saw the library's imports


def test_the_library_imports_neither_plug_in():
    for name, is_pkg, tree in _modules(SRC, "forcespace"):
        for target, _ in _imports(name, is_pkg, tree):
            assert not target.startswith(tuple(PLUGINS)), f"{name} imports {target}"


def test_the_plug_ins_use_the_public_api_only():
    for package, root in PLUGINS.items():
        for name, is_pkg, tree in _modules(root, package):
            for target, imported in _imports(name, is_pkg, tree):
                if not target.startswith("forcespace") or target.startswith(package):
                    continue
                assert not target.startswith("forcespace.cli"), f"{name} imports the CLI"
                assert not any(part.startswith("_") for part in target.split(".")), \
                    f"{name} imports private module {target}"
                assert not (imported or "x").startswith("_") or imported == "__version__", \
                    f"{name} imports {target}.{imported}"


def _is_kernel(fn) -> bool:
    for d in fn.decorator_list:
        f = d.func if isinstance(d, ast.Call) else d
        if getattr(f, "id", getattr(f, "attr", "")) in ("kernel", "njit", "jit"):
            return True
    return False


def test_functions_are_short_and_kernels_take_named_state():
    long, wide = [], []
    for name, _, tree in _modules(SRC, "forcespace"):
        for fn in ast.walk(tree):
            if not isinstance(fn, (ast.FunctionDef, ast.AsyncFunctionDef)):
                continue
            lines = fn.end_lineno - fn.lineno + 1
            if _is_kernel(fn):
                n_args = len(fn.args.args) + len(fn.args.kwonlyargs)
                if n_args > MAX_KERNEL_ARGS:
                    wide.append(f"{name}.{fn.name}: {n_args} parameters")
            elif lines > MAX_LINES:
                long.append(f"{name}.{fn.name}: {lines} lines")
    assert long == []
    assert wide == []


def test_errors_cross_process_boundaries_intact():
    """A task's InputError raised in a pool worker reaches the study as the same error
    (it once arrived as BrokenProcessPool: the default pickling lost its fields)."""
    import pickle

    from forcespace.errors import InputError, NumericalError
    e = pickle.loads(pickle.dumps(InputError("a.toml", "disks.n", "must be >= 1", got=0)))
    assert isinstance(e, InputError) and str(e) == "a.toml: disks.n = 0: must be >= 1"
    assert (e.source, e.field, e.got) == ("a.toml", "disks.n", 0)
    assert str(pickle.loads(pickle.dumps(NumericalError("no")))) == "no"


# the engine's entry points: the only engine functions that take the scene (and turn it
# into records, forcespace.model.setup.Setup, at once)
SCENE_ENTRY_POINTS = {"forcespace.engine.protocol": {"build_packing", "jam"}}


def test_the_engine_reads_the_scene_only_at_its_entry_points():
    """Below build_packing/jam no function takes a scene or reads a "section.key" of one:
    the engine runs on the records of model.setup (boundary conditions as data)."""
    readers, seen = [], 0
    for name, _, tree in _modules(SRC / "engine", "forcespace.engine"):
        allowed = SCENE_ENTRY_POINTS.get(name, set())
        for fn in ast.walk(tree):
            if not isinstance(fn, (ast.FunctionDef, ast.AsyncFunctionDef)):
                continue
            seen += 1
            params = {a.arg for a in fn.args.args + fn.args.kwonlyargs}
            keys = [s.slice.value for s in ast.walk(fn) if isinstance(s, ast.Subscript)
                    and isinstance(s.slice, ast.Constant) and isinstance(s.slice.value, str)
                    and "." in s.slice.value]
            if fn.name not in allowed and ("scene" in params or keys):
                readers.append(f"{name}.{fn.name}: {keys or 'takes a scene'}")
    assert seen > 70            # the walk saw the engine's functions
    assert readers == []
