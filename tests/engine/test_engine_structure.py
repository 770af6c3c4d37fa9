"""The engine's house rules (issue 20), checked on its sources: kernels take named state
(at most 12 parameters), no function outside a kernel over 80 lines, no import of another
module's private names, no import cycle between its modules; and nowhere in the library a
random stream seeded outside ``forcespace/streams.py``."""
import ast
from pathlib import Path

import forcespace
import forcespace.engine

ENGINE = Path(forcespace.engine.__file__).parent
MODULES = {p.stem: ast.parse(p.read_text(), str(p)) for p in sorted(ENGINE.glob("*.py"))}


def _is_kernel(fn: ast.FunctionDef) -> bool:
    for d in fn.decorator_list:
        target = d.func if isinstance(d, ast.Call) else d
        if getattr(target, "id", getattr(target, "attr", "")) in ("kernel", "njit"):
            return True
    return False


def _functions():
    for name, tree in MODULES.items():
        for node in ast.walk(tree):
            if isinstance(node, ast.FunctionDef):
                yield name, node


def test_kernels_take_at_most_12_parameters_and_other_functions_fit_80_lines():
    kernels = 0
    for module, fn in _functions():
        if _is_kernel(fn):
            kernels += 1
            n = len(fn.args.args) + len(fn.args.kwonlyargs)
            assert n <= 12, f"{module}.{fn.name}: {n} parameters"
        else:
            lines = fn.end_lineno - fn.lineno + 1
            assert lines <= 80, f"{module}.{fn.name}: {lines} lines"
    assert kernels >= 10       # the walk found the kernels


def test_no_private_imports_and_no_cycles_between_engine_modules():
    graph = {}
    for module, tree in MODULES.items():
        graph[module] = set()
        for node in ast.walk(tree):
            if isinstance(node, ast.ImportFrom):
                private = [a.name for a in node.names if a.name.startswith("_")
                           and a.name != "__future__"]
                assert not private, f"{module} imports private names {private}"
                if node.level == 1 and node.module in MODULES:
                    graph[module].add(node.module)

    def visit(m, path):
        assert m not in path, f"import cycle {' -> '.join(path + [m])}"
        for d in graph[m]:
            visit(d, path + [m])

    for m in graph:
        visit(m, [])


def test_random_streams_are_derived_in_streams_only():
    src = Path(forcespace.__file__).parent
    seen = 0
    for path in sorted(src.rglob("*.py")):
        if path == src / "streams.py":
            continue
        text = ast.unparse(ast.parse(path.read_text(), str(path)))
        seen += 1
        for word in ("default_rng", "SeedSequence", "7919", "1000003", "1_000_003",
                     "0x9E3779B97F4A7C15", "0x5EED", "RandomState", "np.random.seed"):
            assert word not in text, f"{path.relative_to(src)} seeds a random stream ({word})"
    assert seen > 40