"""The house rules, read off the source by one walk of its syntax trees.

Every Python file of the library (``src/forcespace``) and of its plug-ins (the DEM adapters
under ``adapters/``; the studies under ``studies/``, their package and the top-level
scripts alike) is parsed once into a :class:`Source`: its imports (static, inside
functions, and dynamic: ``importlib.import_module``/``__import__``), the names bound to
modules (``import a.b as m``) and what is read through them (``m._x``), its functions
(length, kernel or not, parameters) and its docstrings. The rules:

* the library: no import cycle (``if TYPE_CHECKING:`` blocks are annotations, not
  imports); no other module's private (underscore) name, imported or read through a module
  alias; never a plug-in; ``io`` imports no stage above it; functions at most ``MAX_LINES`` lines, numba kernels at most
  ``MAX_KERNEL_LINES`` lines and ``MAX_KERNEL_ARGS`` parameters (they take records); the
  engine takes the scene only at its entry points; random streams seeded in
  ``streams.py`` only;
* the plug-ins: only the declared surface (``forcespace.extend``'s docstring): names of
  ``forcespace.__all__`` and ``forcespace.extend.__all__``, the modules ``forcespace.errors``
  and ``forcespace.config``; no private name; dynamic imports included;
* everywhere: a docstring that names a module (``forcespace.x.y``, ``name.py``) names one
  that exists (or a file the code writes).
"""
from __future__ import annotations

import ast
import functools
import importlib
import importlib.util
import re
from dataclasses import dataclass, field
from pathlib import Path

import forcespace
import forcespace.extend

SRC = Path(forcespace.__file__).parent
ROOT = SRC.parents[1]
PLUGIN_ROOTS = (ROOT / "adapters", ROOT / "studies")
PLUGIN_PACKAGES = ("forcespace_adapters", "forcespace_studies")
MAX_LINES = 80          # a function longer than this does more than one thing
MAX_KERNEL_LINES = 120  # a numba kernel's hot loop cannot be split without a cost; one
                        # loop still fits one and a half screens (longest today: 94)
MAX_KERNEL_ARGS = 12    # kernels take records of named state, not dozens of arrays
# the plug-ins' surface: modules they may import, and the names of the two API modules
PLUGIN_MODULES = {"forcespace", "forcespace.extend", "forcespace.errors", "forcespace.config"}
PUBLIC = set(forcespace.__all__) | {"config", "errors", "extend", "__version__"}
SURFACE = {"forcespace": PUBLIC, "forcespace.extend": set(forcespace.extend.__all__)}
# the engine's entry points: the only engine functions that take the scene (and turn it
# into records, forcespace.model.setup.Setup, at once)
SCENE_ENTRY_POINTS = {"forcespace.engine.protocol": {"build_packing", "jam"}}
# dotted names in docstrings that are not modules: the plug-ins' entry-point group
NOT_MODULES = {"forcespace.commands"}


@dataclass
class Import:
    target: str            # the module imported from (absolute)
    name: str | None       # the name imported from it (None: the module itself)
    line: int
    dynamic: bool = False


@dataclass
class Function:
    name: str
    line: int
    lines: int
    kernel: bool
    params: list
    keys: list             # "section.key" string subscripts inside it


@dataclass
class Source:
    """One parsed file: what the rules read of it."""

    path: Path
    module: str | None     # dotted name (None: a script)
    imports: list = field(default_factory=list)
    aliases: dict = field(default_factory=dict)     # local name -> module it is bound to
    through: list = field(default_factory=list)     # (alias, attribute, line) read
    functions: list = field(default_factory=list)
    docstrings: list = field(default_factory=list)  # (line, text)
    strings: set = field(default_factory=set)       # every string constant of the code

    @property
    def where(self) -> str:
        return str(self.path.relative_to(ROOT))


def _module_name(path: Path) -> tuple[str | None, str | None]:
    """(dotted module name, package relative imports start from) of a file."""
    for root, package in ((SRC, "forcespace"), (ROOT / "adapters" / PLUGIN_PACKAGES[0],
                          PLUGIN_PACKAGES[0]), (ROOT / "studies" / PLUGIN_PACKAGES[1],
                          PLUGIN_PACKAGES[1])):
        if root in path.parents:
            parts = list(path.relative_to(root).with_suffix("").parts)
            is_pkg = parts[-1] == "__init__"
            name = ".".join([package] + (parts[:-1] if is_pkg else parts))
            return name, name if is_pkg else name.rpartition(".")[0]
    return None, None


def _is_kernel(fn) -> bool:
    for d in fn.decorator_list:
        f = d.func if isinstance(d, ast.Call) else d
        if getattr(f, "id", getattr(f, "attr", "")) in ("kernel", "njit", "jit"):
            return True
    return False


def _type_checking(tree) -> set:
    return {id(n) for node in ast.walk(tree) if isinstance(node, ast.If)
            and getattr(node.test, "id", getattr(node.test, "attr", "")) == "TYPE_CHECKING"
            for child in node.body for n in ast.walk(child)}


def _absolute(node: ast.ImportFrom, package: str | None) -> str:
    if not node.level:
        return node.module or ""
    base = (package or "").split(".")
    base = base[:len(base) - node.level + 1]
    return ".".join(base + ([node.module] if node.module else []))


@functools.lru_cache(maxsize=None)
def parse(path: Path) -> Source:
    """The one walk of a file's syntax tree."""
    tree = ast.parse(path.read_text(), str(path))
    module, package = _module_name(path)
    src = Source(path, module)
    skip = _type_checking(tree)
    for node in ast.walk(tree):
        if id(node) in skip:
            continue
        if isinstance(node, ast.Import):
            for a in node.names:
                src.imports.append(Import(a.name, None, node.lineno))
                src.aliases[a.asname or a.name.split(".")[0]] = \
                    a.name if a.asname else a.name.split(".")[0]
        elif isinstance(node, ast.ImportFrom):
            target = _absolute(node, package)
            for a in node.names:
                src.imports.append(Import(target, a.name, node.lineno))
                src.aliases[a.asname or a.name] = f"{target}.{a.name}"
        elif isinstance(node, ast.Call):
            f = node.func
            if getattr(f, "attr", getattr(f, "id", "")) in ("import_module", "__import__"):
                for arg in node.args[:1]:
                    names = ([arg.value] if isinstance(arg, ast.Constant) else
                             [s.value for s in ast.walk(tree) if isinstance(s, ast.Constant)
                              and isinstance(s.value, str)
                              and re.fullmatch(r"forcespace(\.\w+)+", s.value)])
                    src.imports += [Import(n, None, node.lineno, dynamic=True)
                                    for n in names if isinstance(n, str)]
        elif isinstance(node, ast.Attribute) and isinstance(node.value, ast.Name):
            src.through.append((node.value.id, node.attr, node.lineno))
        elif isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef)):
            keys = [s.slice.value for s in ast.walk(node) if isinstance(s, ast.Subscript)
                    and isinstance(s.slice, ast.Constant) and isinstance(s.slice.value, str)
                    and "." in s.slice.value]
            src.functions.append(Function(
                node.name, node.lineno, node.end_lineno - node.lineno + 1, _is_kernel(node),
                [a.arg for a in node.args.args + node.args.kwonlyargs], keys))
        elif isinstance(node, ast.Constant) and isinstance(node.value, str):
            src.strings.add(node.value)
        if isinstance(node, (ast.Module, ast.ClassDef, ast.FunctionDef,
                             ast.AsyncFunctionDef)):
            doc = ast.get_docstring(node, clean=False)
            if doc:
                src.docstrings.append((getattr(node, "lineno", 1), doc))
    return src


def library() -> list[Source]:
    return [parse(p) for p in sorted(SRC.rglob("*.py"))]


def plugins() -> list[Source]:
    return [parse(p) for root in PLUGIN_ROOTS for p in sorted(root.rglob("*.py"))]


def _library_module(dotted: str, modules: set) -> str | None:
    """The library module an import of ``dotted`` lands in (None: not the library's)."""
    while dotted and dotted not in modules:
        dotted = dotted.rpartition(".")[0]
    return dotted or None


def _private(name: str | None) -> bool:
    return bool(name) and name.startswith("_") and not name.startswith("__")


# ---- the library ------------------------------------------------------------------------
def _graph():
    srcs = library()
    modules = {s.module for s in srcs}
    edges, private = {}, []
    for s in srcs:
        for imp in s.imports:
            full = f"{imp.target}.{imp.name}" if imp.name else imp.target
            dest = _library_module(full, modules)
            if dest is None:
                continue
            if imp.name and dest == imp.target and _private(imp.name):
                private.append(f"{s.where}:{imp.line} imports {imp.target}.{imp.name}")
            if dest not in (s.module, "forcespace"):   # the package's lazy __init__ aside
                edges.setdefault(s.module, set()).add(dest)
        for alias, attr, line in s.through:
            bound = s.aliases.get(alias)
            dest = _library_module(bound, modules) if bound else None
            if dest and dest != s.module and bound == dest and _private(attr):
                private.append(f"{s.where}:{line} reads {bound}.{attr} through {alias}")
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
    edges, private = _graph()
    assert not _cycles(edges), "\n".join(_cycles(edges))
    assert not private, "\n".join(private)
    assert len(edges) > 30          # the walk saw the library's imports


def test_the_library_imports_neither_plug_in():
    wrong = [f"{s.where}:{i.line} imports {i.target}" for s in library() for i in s.imports
             if i.target.startswith(PLUGIN_PACKAGES)]
    assert not wrong, "\n".join(wrong)


# io is the edge: the stages read and write files through it, it imports none of them
# (the model's nouns it reads and writes, errors, config and the kernel stamp aside)
IO_MAY_IMPORT = ("forcespace.io", "forcespace.model", "forcespace.errors", "forcespace.config",
                 "forcespace.kernels")


def test_io_imports_no_stage_above_it():
    wrong = []
    for s in library():
        if not (s.module or "").startswith("forcespace.io"):
            continue
        for imp in s.imports:
            full = f"{imp.target}.{imp.name}" if imp.name else imp.target
            if not full.startswith("forcespace") or full == "forcespace.__version__":
                continue
            if not full.startswith(IO_MAY_IMPORT):
                wrong.append(f"{s.where}:{imp.line} imports {full}")
    assert not wrong, "\n".join(wrong)


def test_functions_are_short_and_kernels_take_named_state():
    long, kernels = [], 0
    for s in library():
        for fn in s.functions:
            kernels += fn.kernel
            limit = MAX_KERNEL_LINES if fn.kernel else MAX_LINES
            if fn.lines > limit:
                long.append(f"{s.where}:{fn.line} {fn.name}: {fn.lines} lines > {limit}")
            if fn.kernel and len(fn.params) > MAX_KERNEL_ARGS:
                long.append(f"{s.where}:{fn.line} {fn.name}: {len(fn.params)} parameters")
    assert kernels >= 20            # the walk found the kernels
    assert not long, "\n".join(long)


def test_the_engine_reads_the_scene_only_at_its_entry_points():
    """Below build_packing/jam no function takes a scene or reads a "section.key" of one:
    the engine runs on the records of model.setup (boundary conditions as data)."""
    readers, seen = [], 0
    for s in library():
        if not (s.module or "").startswith("forcespace.engine"):
            continue
        allowed = SCENE_ENTRY_POINTS.get(s.module, set())
        for fn in s.functions:
            seen += 1
            if fn.name not in allowed and ("scene" in fn.params or fn.keys):
                readers.append(f"{s.where}:{fn.line} {fn.name}: {fn.keys or 'a scene'}")
    assert seen > 70            # the walk saw the engine's functions
    assert not readers, "\n".join(readers)


def test_random_streams_are_derived_in_streams_only():
    words = ("default_rng", "SeedSequence", "7919", "1000003", "1_000_003",
             "0x9E3779B97F4A7C15", "0x5EED", "RandomState", "np.random.seed")
    wrong = []
    for s in library():
        if s.path == SRC / "streams.py":
            continue
        text = ast.unparse(ast.parse(s.path.read_text()))
        wrong += [f"{s.where} seeds a random stream ({w})" for w in words if w in text]
    assert not wrong, "\n".join(wrong)


# ---- the plug-ins -------------------------------------------------------------------------
def _plugin_violations(s: Source) -> list[str]:
    """What ``s`` (a plug-in file) reaches beyond the declared surface."""
    wrong = []
    for imp in s.imports:
        if not imp.target.startswith("forcespace") or imp.target.startswith(PLUGIN_PACKAGES):
            continue
        how = "dynamically imports" if imp.dynamic else "imports"
        what = f"{imp.target}.{imp.name}" if imp.name else imp.target
        if imp.target not in PLUGIN_MODULES:
            wrong.append(f"{s.where}:{imp.line} {how} {what}: not the extension surface")
        elif imp.name and imp.target in SURFACE and imp.name not in SURFACE[imp.target]:
            wrong.append(f"{s.where}:{imp.line} {how} {what}: not in {imp.target}.__all__")
        elif _private(imp.name):
            wrong.append(f"{s.where}:{imp.line} {how} private {what}")
    for alias, attr, line in s.through:
        bound = s.aliases.get(alias, "")
        if not bound.startswith("forcespace") or bound.startswith(PLUGIN_PACKAGES):
            continue
        if bound in SURFACE and attr not in SURFACE[bound] or _private(attr):
            wrong.append(f"{s.where}:{line} reads {bound}.{attr} through {alias}")
    return wrong


def test_the_plug_ins_use_the_declared_surface_only():
    srcs = plugins()
    assert sum(s.module is None for s in srcs) >= 5      # the studies' scripts are read
    assert sum(len(s.imports) for s in srcs) > 100        # and their imports
    wrong = [w for s in srcs for w in _plugin_violations(s)]
    assert not wrong, "\n".join(wrong)


def _resolves_import(imp: Import) -> bool:
    try:
        module = importlib.import_module(imp.target)
    except ImportError:
        return False
    return imp.name in (None, "*") or hasattr(module, imp.name) or \
        importlib.util.find_spec(f"{imp.target}.{imp.name}") is not None


def test_what_the_plug_ins_import_of_forcespace_exists():
    """An import of a forcespace module or name that no longer exists fails when the line
    runs, which for a study script may be months later (bench_select imported a module
    gone since the restructure)."""
    dead = [f"{s.where}:{i.line} {i.target}" + (f".{i.name}" if i.name else "")
            for s in plugins() for i in s.imports
            if i.target.startswith("forcespace") and not _resolves_import(i)]
    assert not dead, "\n".join(dead)


def test_the_extension_surface_resolves():
    for name in forcespace.extend.__all__:
        assert getattr(forcespace.extend, name) is not None, name


# ---- docstrings -----------------------------------------------------------------------------
DOTTED = re.compile(r"\b(forcespace(?:_studies|_adapters)?(?:\.[A-Za-z_]\w*)+)")
PY_FILE = re.compile(r"(?<![\w/.-])([A-Za-z_]\w*\.py)\b")


@functools.lru_cache(maxsize=None)
def _resolves(dotted: str) -> bool:
    parts = dotted.split(".")
    for i in range(len(parts), 0, -1):
        try:
            obj = importlib.import_module(".".join(parts[:i]))
        except ImportError:
            continue
        for attr in parts[i:]:
            fields = getattr(obj, "__dataclass_fields__", {})
            if attr in fields or attr in getattr(obj, "_fields", ()):
                return True           # a record's field: no class attribute to find
            if not hasattr(obj, attr):
                return False
            obj = getattr(obj, attr)
        return True
    return False


def test_docstrings_name_modules_that_exist():
    srcs = library() + plugins()
    files = {p.name for root in (SRC, *PLUGIN_ROOTS, ROOT / "tests") for p in root.rglob("*.py")}
    written = set().union(*(s.strings for s in srcs))     # files the code writes
    wrong, seen = [], 0
    for s in srcs:
        for line, doc in s.docstrings:
            for m in DOTTED.finditer(doc):
                seen += 1
                if m.group(1) not in NOT_MODULES and not _resolves(m.group(1)):
                    wrong.append(f"{s.where}:{line} {m.group(1)}")
            for m in PY_FILE.finditer(doc):
                if m.group(1) not in files and m.group(1) not in written:
                    wrong.append(f"{s.where}:{line} {m.group(1)}")
    assert seen > 50
    assert not wrong, "\n".join(wrong)


def test_errors_cross_process_boundaries_intact():
    """A task's InputError raised in a pool worker reaches the study as the same error
    (it once arrived as BrokenProcessPool: the default pickling lost its fields)."""
    import pickle

    from forcespace.errors import InputError, NumericalError
    e = pickle.loads(pickle.dumps(InputError("a.toml", "disks.n", "must be >= 1", got=0)))
    assert isinstance(e, InputError) and str(e) == "a.toml: disks.n = 0: must be >= 1"
    assert (e.source, e.field, e.got) == ("a.toml", "disks.n", 0)
    assert str(pickle.loads(pickle.dumps(NumericalError("no")))) == "no"
