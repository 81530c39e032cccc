"""The cells a notebook's public checks need: a conservative backward slice over its top-level statements, computed
statically with `ast` (nothing runs), so that the grader and the self-check run only those statements of a notebook
(armlab_course.grading.public.run_public) and give the verdict of the notebook run from the top.

The units are the top-level statements of the code cells up to the last target (a check cell is one unit, kept
whole). Per unit, at the notebook's top level (a function's parameters and locals are its own):

- *defs*: the names it binds (assignments, imports, def/class, for/with/except targets, walrus);
- *reads*: the names whose value from an earlier unit it may read -- every name loaded before the unit binds it
  unconditionally, and every name a function, lambda, class or comprehension of it loads without binding it (it may
  run later); calling a function of the notebook reads what its body reads;
- *changes* (_effects): the names whose objects it may change -- a method call on it, a call it goes into (but a
  builtin's that changes nothing, numpy's or math's), an attribute or item written, an augmented assignment, a
  `with`, iteration over anything but a fresh list, tuple, dict or set (an iterator is used up); a function of the
  notebook it calls may change whatever its body reads;
- *links*: names whose objects it may tie together (what it binds and what the value holds, what goes into one
  call): their objects form one component.

An object is a name with the units whose binding of it may reach a point (the last unit binding it whenever it
runs, and any binding it only maybe after that). A unit joins the slice when it binds an object a unit of the slice
reads, or when it may change an object in the component of one a unit of the slice reads. The slice is the fixed
point from the target units. Besides:

- A unit that cannot be analysed -- not Python (an IPython magic, a shell escape), `global`/`nonlocal`, a star
  import, or reaching the namespace or the interpreter by other means than names (`exec`, `eval`, `globals()`,
  `setattr`, `__import__`, `importlib`, `sys`, `os`, `builtins`, `get_ipython`...) -- joins, with every unit before
  it.
- Global random state (the `random` module, `np.random.<function>` other than making a generator of one's own) is
  one shared object, "<random state>", changed by every unit touching it; so is the file system, "<files>", for every
  unit that names a file API (open, Path, tempfile, save/load...).
- A name bound only by `import` (a module, a library's function or class) or a builtin is shared state only through
  the units that write into it (an attribute or item assignment, np.set_printoptions, a seed...): a unit that only
  uses it (np.array, cv2.cvtColor, make_station) does not join through it, but it needs the units that import it.
  So is a function or class of the notebook that holds no state of its own (_pure).

What the slice cannot see is state hidden inside a library call of a unit left out (a cache a kit function fills,
a singleton two calls share): a kit function given no object of the slice is taken to change none. The kit keeps
run state in the objects a notebook names (a station, a session), which the slice follows.
tests/course/test_grading_slicing.py holds the rules.
"""

from __future__ import annotations

import ast
import builtins
import json
from collections.abc import Iterable, Sequence
from dataclasses import dataclass, field
from pathlib import Path

__all__ = ["CellNames", "cell_names", "public_slice", "slice_notebook", "explain", "UNKNOWN", "RANDOM_STATE", "FILES"]

UNKNOWN = "<unknown>"             # a cell that cannot be analysed: it joins, with every cell before it
RANDOM_STATE = "<random state>"
FILES = "<files>"
# reaching the namespace or the interpreter by other ways than names
_OPAQUE = {"exec", "eval", "compile", "globals", "locals", "vars", "setattr", "delattr", "__import__", "__builtins__",
           "builtins", "importlib", "sys", "os", "get_ipython", "input", "breakpoint", "ctypes", "gc", "inspect"}
_FILE_NAMES = {"open", "Path", "PurePath", "tempfile", "shutil", "pathlib", "glob", "pickle", "json", "savefig",
               "save", "savez", "savez_compressed", "savetxt", "load", "loadtxt", "genfromtxt", "fromfile", "tofile",
               "write_text", "read_text", "write_bytes", "read_bytes", "imwrite", "imread", "mkdtemp", "mkstemp",
               "NamedTemporaryFile", "TemporaryDirectory", "to_viewer", "unlink", "mkdir", "rmtree", "csv"}
# calls that change a library's global state although they only read the library's name
_SETTERS = {"seed", "set_printoptions", "setLogLevel", "setNumThreads", "rc", "rcParams", "rcdefaults", "use",
            "filterwarnings", "simplefilter", "resetwarnings", "seterr", "set_state", "setUseOptimized",
            "setRNGSeed", "register", "patch", "update", "clear", "append", "extend", "insert", "pop", "remove",
            "setdefault", "popitem", "add", "discard"}
# np.random / random functions that make a generator of one's own (no global state)
_OWN_RNG = {"default_rng", "Generator", "RandomState", "SeedSequence", "PCG64", "PCG64DXSM", "Philox", "SFC64",
            "MT19937", "BitGenerator", "Random"}


@dataclass
class CellNames:
    """What one cell shares with others (see the module's text): `defs`, `reads`, `imports` (names it binds by
    import), `written` (names whose object it writes into through an attribute, an item or a setter call)."""

    defs: set[str] = field(default_factory=set)
    reads: set[str] = field(default_factory=set)
    imports: set[str] = field(default_factory=set)
    written: set[str] = field(default_factory=set)
    pure: set[str] = field(default_factory=set)
    functions: set[str] = field(default_factory=set)  # bound by a def or class statement
    mutated: set[str] = field(default_factory=set)    # names whose object the cell may change (_effects)
    linked: set[str] = field(default_factory=set)     # names whose objects the cell may tie together (_effects)
    iterated: set[str] = field(default_factory=set)   # names whose objects it iterates over (uses up an iterator)
    containers: set[str] = field(default_factory=set)  # names it binds to a fresh list, tuple, dict or set
    kills: set[str] = field(default_factory=set)      # bound whenever the cell runs: an earlier value is gone

    @property
    def opaque(self) -> bool:
        return UNKNOWN in self.reads


def _chain(node: ast.AST) -> list[str]:
    """a.b.c -> ['a', 'b', 'c'] (a Name at the base, subscripts and calls looked through), else []."""
    parts = []
    while isinstance(node, (ast.Attribute, ast.Subscript, ast.Call)):
        if isinstance(node, ast.Attribute):
            parts.append(node.attr)
            node = node.value
        elif isinstance(node, ast.Subscript):
            node = node.value
        else:
            node = node.func
    return [node.id, *reversed(parts)] if isinstance(node, ast.Name) else []


def _targets(node: ast.AST) -> set[str]:
    """The plain names a binding target binds (a, (a, b), [a, *b]); an attribute or item target binds none."""
    if isinstance(node, ast.Name):
        return {node.id}
    if isinstance(node, (ast.Tuple, ast.List)):
        return set().union(*(_targets(e) for e in node.elts)) if node.elts else set()
    if isinstance(node, ast.Starred):
        return _targets(node.value)
    return set()


_SCOPES = (ast.FunctionDef, ast.AsyncFunctionDef, ast.Lambda, ast.ClassDef, ast.ListComp, ast.SetComp,
           ast.DictComp, ast.GeneratorExp)


def _free(scope: ast.AST) -> set[str]:
    """The names a nested scope (function, lambda, class, comprehension) loads and does not bind itself: the
    module-level names it may read whenever it runs (over-approximated: a name bound anywhere inside counts as
    bound)."""
    loaded, bound = set(), set()
    for node in ast.walk(scope):
        if isinstance(node, ast.Name):
            (loaded if isinstance(node.ctx, ast.Load) else bound).add(node.id)
        elif isinstance(node, ast.arg):
            bound.add(node.arg)
        elif isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef, ast.ClassDef)) and node is not scope:
            bound.add(node.name)
        elif isinstance(node, (ast.Import, ast.ImportFrom)):
            bound |= {a.asname or a.name.split(".")[0] for a in node.names}
        elif isinstance(node, ast.ExceptHandler) and node.name:
            bound.add(node.name)
    if isinstance(scope, (ast.FunctionDef, ast.AsyncFunctionDef, ast.ClassDef)):
        bound.discard(scope.name)
        # decorators, defaults and bases are evaluated where the def is, but reading them counts just the same
    return loaded - bound


def _constant(node: ast.AST | None) -> bool:
    """An immutable literal (a number, a string, None, a tuple of them)."""
    if node is None or isinstance(node, ast.Constant):
        return True
    if isinstance(node, ast.Tuple):
        return all(_constant(e) for e in node.elts)
    if isinstance(node, ast.UnaryOp):
        return _constant(node.operand)
    return False


def _pure(s: ast.stmt) -> bool:
    """A def or class statement whose object holds no state of its own: no decorator, only constant default
    arguments, and for a class, a body of methods, docstrings and constant attributes, with no method reaching the
    class through `__class__` or `type(...)` (instances hold their own state; a free name a method reads is read by
    every call, see public_slice)."""
    if s.decorator_list:
        return False
    if isinstance(s, ast.ClassDef):
        if s.keywords:
            return False
        for b in s.body:
            if isinstance(b, (ast.FunctionDef, ast.AsyncFunctionDef)):
                if not _pure(b) and any(not isinstance(d, ast.Name) or d.id not in ("staticmethod", "classmethod",
                                                                                    "property")
                                        for d in b.decorator_list):
                    return False
                if b.decorator_list and not all(_constant(d) for d in b.args.defaults + b.args.kw_defaults):
                    return False
            elif isinstance(b, ast.Expr) and isinstance(b.value, ast.Constant):
                continue
            elif isinstance(b, (ast.Assign, ast.AnnAssign)) and _constant(b.value):
                continue
            else:
                return False
        return not any((isinstance(n, ast.Attribute) and n.attr == "__class__") or
                       (isinstance(n, ast.Call) and isinstance(n.func, ast.Name) and n.func.id == "type")
                       for n in ast.walk(s))
    args = s.args
    return all(_constant(d) for d in args.defaults + args.kw_defaults)


# calls that change none of their arguments, and return a fresh value holding none of them
_NEW_VALUE = {"len", "str", "repr", "int", "float", "bool", "complex", "isinstance", "issubclass", "hash", "id", "abs",
              "round", "format", "chr", "ord", "hex", "bin", "oct", "divmod", "pow", "print", "any", "all", "callable",
              "hasattr"}
# builtins that change none of their arguments (they may return one, or a container holding them)
_PURE_BUILTINS = _NEW_VALUE | {"list", "tuple", "set", "frozenset", "dict", "sorted", "min", "max", "sum", "type",
                               "enumerate", "zip", "range", "reversed", "slice", "getattr"}
# numpy's and math's functions change none of their arguments, but these (and any call given out=)
_NUMPY_MUTATORS = {"copyto", "put", "place", "putmask", "fill_diagonal", "put_along_axis", "shuffle", "seed"}
_PURE_MODULES = {"np", "numpy", "math"}
# methods that change nothing of their object (numpy arrays, str, dict, list reads)
_PURE_METHODS = {"copy", "sum", "mean", "max", "min", "std", "var", "round", "astype", "reshape", "tolist", "item",
                 "any", "all", "argmax", "argmin", "argsort", "nonzero", "dot", "transpose", "ravel", "flatten",
                 "cumsum", "prod", "squeeze", "get", "keys", "values", "items", "count", "index", "startswith",
                 "endswith", "format", "join", "split", "splitlines", "strip", "rstrip", "lstrip", "lower", "upper",
                 "isdigit", "isalpha"}


def _objects(node: ast.AST | None) -> set[str]:
    """The names whose objects the value of expression `node` may be or hold (what binding it to a name aliases)."""
    if node is None or isinstance(node, (ast.Constant, ast.JoinedStr, ast.Compare)):
        return set()
    if isinstance(node, ast.Name):
        return {node.id}
    if isinstance(node, (ast.Attribute, ast.Subscript, ast.Starred, ast.Await, ast.FormattedValue)):
        return _objects(node.value)
    if isinstance(node, ast.UnaryOp):
        return set() if isinstance(node.op, ast.Not) else _objects(node.operand)
    if isinstance(node, ast.Call):
        if isinstance(node.func, ast.Name) and node.func.id in _NEW_VALUE:
            return set()
        out = _objects(node.func)
        for a in [*node.args, *(k.value for k in node.keywords)]:
            out |= _objects(a)
        return out
    if isinstance(node, _SCOPES):
        return _free(node)
    return set().union(*(_objects(c) for c in ast.iter_child_nodes(node)))


def _pure_call(node: ast.Call) -> bool:
    """A call that changes none of its arguments (a builtin, numpy's or math's functions)."""
    if any(k.arg == "out" for k in node.keywords):
        return False
    if isinstance(node.func, ast.Name):
        return node.func.id in _PURE_BUILTINS
    chain = _chain(node.func)
    return len(chain) >= 2 and chain[0] in _PURE_MODULES and chain[-1] not in _NUMPY_MUTATORS and \
        "random" not in chain


_CONTAINER_CALLS = {"list", "tuple", "dict", "set", "sorted", "frozenset"}


def _container(node: ast.AST | None) -> bool:
    """A fresh list, tuple, dict or set (a display, a comprehension, list(...), a sum of them): iterating over it uses
    nothing up."""
    if isinstance(node, (ast.List, ast.Tuple, ast.Dict, ast.Set, ast.ListComp, ast.DictComp, ast.SetComp)):
        return True
    if isinstance(node, ast.BinOp):
        return _container(node.left) and _container(node.right)
    return isinstance(node, ast.Call) and isinstance(node.func, ast.Name) and node.func.id in _CONTAINER_CALLS


def _effects(statement: ast.stmt) -> tuple[set[str], set[str], set[str]]:
    """(mutated, linked, iterated) of one top-level statement: the names whose objects it may change -- by a method
    call or any call they go into (but _pure_call), an attribute or item written, an augmented assignment, a `with`
    -- the names whose objects it may tie together (what it binds, and what goes into one call), and the names whose
    objects it iterates over (an iterator is used up: a change, unless the object is a fresh container,
    public_slice). Function and class bodies run when called: a call reads their free names (public_slice)."""
    mutated, linked, iterated = set(), set(), set()
    stack = [statement]
    if isinstance(statement, (ast.FunctionDef, ast.AsyncFunctionDef, ast.ClassDef)):   # what runs at the def
        stack = [*statement.decorator_list, *getattr(statement, "bases", []),
                 *(k.value for k in getattr(statement, "keywords", []))]
        if not isinstance(statement, ast.ClassDef):
            stack += [*statement.args.defaults, *(d for d in statement.args.kw_defaults if d is not None)]
    while stack:
        n = stack.pop()
        if isinstance(n, (ast.FunctionDef, ast.AsyncFunctionDef, ast.ClassDef, ast.Lambda)) and n is not statement:
            linked |= _objects(n) if isinstance(n, ast.Lambda) else set()
            continue
        if isinstance(n, ast.Call):
            func = n.func
            pure = _pure_call(n)
            if isinstance(func, ast.Attribute):
                if func.attr not in _PURE_METHODS and not pure:
                    mutated |= _objects(func.value)
            elif not (isinstance(func, ast.Name) and func.id in _PURE_BUILTINS):
                mutated |= _objects(func)
            if not pure:
                for a in [*n.args, *(k.value for k in n.keywords)]:
                    mutated |= _objects(a)
            linked |= _objects(n)
        elif isinstance(n, (ast.Attribute, ast.Subscript)) and isinstance(n.ctx, (ast.Store, ast.Del)):
            mutated |= _objects(n.value)
        elif isinstance(n, ast.AugAssign):
            mutated |= _objects(n.target)
            linked |= _objects(n.value) | _objects(n.target)
        elif isinstance(n, (ast.For, ast.AsyncFor, ast.comprehension)):
            if isinstance(n.iter, (ast.Name, ast.Attribute, ast.Subscript)):
                iterated |= _objects(n.iter)
            else:
                mutated |= _objects(n.iter)
            linked |= _objects(n.iter)
        elif isinstance(n, ast.withitem):
            mutated |= _objects(n.context_expr)
            linked |= _objects(n.context_expr)
        elif isinstance(n, (ast.Assign, ast.AnnAssign, ast.NamedExpr)):
            linked |= _objects(n.value)
        stack.extend(ast.iter_child_nodes(n))
    return mutated, linked | mutated, iterated


class _Cell:
    """Walks one cell's top-level statements in order (see the module's text)."""

    def __init__(self) -> None:
        self.names = CellNames()
        self.sure: set[str] = set()          # bound unconditionally so far at the top level

    def loads(self, node: ast.AST, fresh: set[str] = frozenset()) -> None:
        """Record what evaluating `node` at the top level reads (names in `fresh` are bound by then)."""
        stack = [node]
        while stack:
            n = stack.pop()
            if isinstance(n, _SCOPES):
                self.names.reads |= _free(n)
                self._marks(n)
                continue
            if isinstance(n, ast.Name) and isinstance(n.ctx, ast.Load) and n.id not in self.sure | set(fresh):
                self.names.reads.add(n.id)
            self._mark(n)
            stack.extend(ast.iter_child_nodes(n))

    def _marks(self, scope: ast.AST) -> None:
        for n in ast.walk(scope):
            self._mark(n)

    def _mark(self, n: ast.AST) -> None:
        """The pseudo-names, opaque uses and writes of one node."""
        r, w = self.names.reads, self.names.written
        if isinstance(n, (ast.Global, ast.Nonlocal)):
            r.add(UNKNOWN)
        elif isinstance(n, ast.Name) and n.id in _OPAQUE:
            r.add(UNKNOWN)
        elif isinstance(n, ast.Name) and n.id in _FILE_NAMES:
            r.add(FILES)
        elif isinstance(n, ast.Name) and n.id == "random":
            r.add(RANDOM_STATE)
        elif isinstance(n, ast.Attribute):
            chain = _chain(n)
            if n.attr in _OPAQUE:
                r.add(UNKNOWN)
            if n.attr in _FILE_NAMES:
                r.add(FILES)
            if chain and "random" in chain[:-1] and n.attr not in _OWN_RNG:
                r.add(RANDOM_STATE)
            if chain and (isinstance(n.ctx, (ast.Store, ast.Del)) or n.attr in _SETTERS):
                w.add(chain[0])
        elif isinstance(n, ast.Subscript) and isinstance(n.ctx, (ast.Store, ast.Del)):
            chain = _chain(n.value)
            if chain:
                w.add(chain[0])
        elif isinstance(n, ast.AugAssign):
            chain = _chain(n.target)
            if chain:
                w.add(chain[0])
        elif isinstance(n, (ast.Import, ast.ImportFrom)):
            for alias in n.names:
                top = (n.module if isinstance(n, ast.ImportFrom) and n.module else alias.name).split(".")[0]
                if alias.name == "*" or top in _OPAQUE or alias.name in _OPAQUE:
                    r.add(UNKNOWN)
                if top in _FILE_NAMES or alias.name in _FILE_NAMES:
                    r.add(FILES)
                if "random" in (top, alias.name.split(".")[-1]):
                    r.add(RANDOM_STATE)

    def bind(self, names: set[str], sure: bool) -> None:
        self.names.defs |= names
        if sure:
            self.sure |= names

    def statement(self, s: ast.stmt, sure: bool = True) -> None:
        """One statement; `sure`: it runs whenever the cell does (not inside an if, a loop or a try)."""
        if sure:                       # a top-level statement: its effects, nested statements included
            mutated, linked, iterated = _effects(s)
            self.names.mutated |= mutated
            self.names.linked |= linked | iterated
            self.names.iterated |= iterated
            if isinstance(s, ast.Assign) and _container(s.value):
                self.names.containers |= set().union(*(_targets(t) for t in s.targets)) if len(s.targets) == 1 and \
                    isinstance(s.targets[0], ast.Name) else set()
        if isinstance(s, (ast.Assign, ast.AnnAssign)):
            if s.value is not None:
                self.loads(s.value)
            targets = s.targets if isinstance(s, ast.Assign) else [s.target]
            for t in targets:
                if not isinstance(t, ast.Name):
                    self.loads(t)          # a.b = ..., a[i] = ...: reads a (and writes into it)
                self._marks(t)
            self.bind(set().union(*(_targets(t) for t in targets)), sure and s.value is not None)
        elif isinstance(s, ast.AugAssign):
            self.loads(s.target.value if not isinstance(s.target, ast.Name) else s.target)
            if isinstance(s.target, ast.Name):
                self.names.reads.add(s.target.id)
            self.loads(s.value)
            self._mark(s)
            self.bind(_targets(s.target), sure)
        elif isinstance(s, (ast.Import, ast.ImportFrom)):
            self._mark(s)
            bound = {a.asname or a.name.split(".")[0] for a in s.names if a.name != "*"}
            self.names.imports |= bound
            self.bind(bound, sure)
        elif isinstance(s, (ast.FunctionDef, ast.AsyncFunctionDef, ast.ClassDef)):
            self.loads(s)
            self.bind({s.name}, sure)
            self.names.functions.add(s.name)
            if _pure(s):
                self.names.pure.add(s.name)
        elif isinstance(s, (ast.For, ast.AsyncFor)):
            self.loads(s.iter)
            self._marks(s.target)
            fresh = _targets(s.target)
            inner = _Cell()
            inner.names, inner.sure = self.names, self.sure | fresh
            for b in s.body + s.orelse:
                inner.statement(b, sure=False)
            self.bind(fresh, False)
            self.names.defs |= inner.names.defs
        elif isinstance(s, (ast.With, ast.AsyncWith)):
            for item in s.items:
                self.loads(item.context_expr)
                if item.optional_vars is not None:
                    self._marks(item.optional_vars)
                    self.bind(_targets(item.optional_vars), sure)
            for b in s.body:
                self.statement(b, sure=False)
        elif isinstance(s, (ast.If, ast.While)):
            self.loads(s.test)
            for b in s.body + s.orelse:
                self.statement(b, sure=False)
        elif isinstance(s, ast.Try) or type(s).__name__ == "TryStar":
            for b in s.body + s.orelse + s.finalbody:
                self.statement(b, sure=False)
            for h in s.handlers:
                if h.type is not None:
                    self.loads(h.type)
                if h.name:
                    self.bind({h.name}, False)
                for b in h.body:
                    self.statement(b, sure=False)
        elif isinstance(s, ast.Delete):
            for t in s.targets:
                self.loads(t)
                self._marks(t)
                self.names.reads |= _targets(t)
            self.bind(set().union(*(_targets(t) for t in s.targets)), False)
        else:                             # expressions, assert, return, raise, pass, match...
            self.loads(s)
            for n in ast.walk(s):         # a walrus binds at the top level too
                if isinstance(n, ast.NamedExpr):
                    self.bind(_targets(n.target), False)
        if isinstance(s, ast.Match):
            for n in ast.walk(s):
                if isinstance(n, (ast.MatchAs, ast.MatchStar)) and n.name:
                    self.bind({n.name}, False)
                if isinstance(n, ast.MatchMapping) and n.rest:
                    self.bind({n.rest}, False)


def _module_level(names: CellNames) -> None:
    """Keep of what a cell changes and ties together only the notebook's names (a comprehension's or a function's
    own names are not), and the shared pseudo-names it touches."""
    module = names.reads | names.defs
    names.mutated &= module
    names.linked &= module
    names.iterated &= module


def cell_names(source: str) -> CellNames:
    """The names of one code cell (see the module's text); a cell that cannot be analysed reads UNKNOWN."""
    try:
        tree = ast.parse(source)
        cell = _Cell()
        for s in tree.body:
            cell.statement(s)
    except (SyntaxError, ValueError, RecursionError, MemoryError):
        return CellNames(reads={UNKNOWN})
    cell.names.kills = cell.sure & cell.names.defs
    _module_level(cell.names)
    return cell.names


def _units(source: str) -> list[tuple[int, int, CellNames]] | None:
    """A cell's top-level statements as (first line, last line, their names), 1-based and inclusive, decorators
    included, statements sharing a line merged into one; None for a cell that cannot be parsed."""
    try:
        tree = ast.parse(source)
    except (SyntaxError, ValueError, RecursionError, MemoryError):
        return None
    spans: list[list] = []
    for s in tree.body:
        first = min([s.lineno] + [d.lineno for d in getattr(s, "decorator_list", [])])
        if spans and first <= spans[-1][1]:
            spans[-1][1] = max(spans[-1][1], s.end_lineno)
            spans[-1][2].append(s)
        else:
            spans.append([first, s.end_lineno, [s]])
    out = []
    for first, last, statements in spans:
        cell = _Cell()
        try:
            for s in statements:
                cell.statement(s)
        except (RecursionError, MemoryError):
            return None
        cell.names.kills = cell.sure & cell.names.defs
        _module_level(cell.names)
        out.append((first, last, cell.names))
    return out


def public_slice(sources: Sequence[str], targets: Iterable[int], explain: list[str] | None = None) -> dict[int, str]:
    """What of the code cells (`sources`, the notebook's code cells in order) the target cells need: per code cell
    up to the last target, its source as the slice runs it -- whole, "" when none of it is needed, or with the
    top-level statements not needed blanked (their lines emptied, so every kept line keeps its number). The target
    cells are kept whole, and so is a cell that cannot be parsed. Empty for no target."""
    targets = set(targets)
    if not targets:
        return {}
    last = max(targets)
    units: list[tuple[int, int, int, CellNames]] = []      # (cell, first line, last line, names), in run order
    for i, source in enumerate(sources[:last + 1]):
        parsed = _units(source)
        if parsed is None or i in targets:
            names = CellNames(reads={UNKNOWN}) if parsed is None else cell_names(source)
            units.append((i, 1, max(1, len(source.splitlines())), names))
        else:
            units += [(i, first, end, names) for first, end, names in parsed]
    reasons: dict[int, str] = {}
    kept = _fixed_point([u[3] for u in units], {k for k, u in enumerate(units) if u[0] in targets}, reasons)
    if explain is not None:
        for k in sorted(kept):
            reason = reasons[k]
            explain.append(f"cell {units[k][0]} lines {units[k][1]}-{units[k][2]}: {reason}")
    out = {}
    for i, source in enumerate(sources[:last + 1]):
        mine = [k for k, u in enumerate(units) if u[0] == i]
        if all(k in kept for k in mine):
            out[i] = source
        elif not any(k in kept for k in mine):
            out[i] = ""
        else:
            lines = source.splitlines()
            for k in mine:
                if k not in kept:
                    _, first, end, _ = units[k]
                    lines[first - 1:end] = [""] * (end - first + 1)
            out[i] = "\n".join(lines) + "\n"
    return out


def _fixed_point(cells: list[CellNames], targets: set[int], why: dict[int, str] | None = None) -> set[int]:
    """The units (in run order) the target units need (the module's text); `why`, if given, gets per unit joined
    the reason. An object is a name with the units whose binding of it may reach a point (the last unit binding it
    whenever it runs, and any binding it only maybe after that): two units share an object when they name it with
    a common reaching unit."""
    why = {} if why is None else why
    if not targets:
        return set()
    last = max(targets)
    cells = cells[:last + 1]
    opaque = [i for i, c in enumerate(cells) if c.opaque]
    keep = set(targets) | set(range(max(opaque) + 1 if opaque else 0))
    for i in keep:
        why.setdefault(i, "a check cell" if i in targets else "at or before a statement that cannot be analysed")
    # names bound by import only, and builtins: shared only through the cells that bind or write into them
    rebound = set().union(*(c.defs - c.imports for c in cells))
    library = (set().union(*(c.imports for c in cells)) | set(dir(builtins))) - rebound
    definers: dict[str, set[int]] = {}
    for i, c in enumerate(cells):
        for n in (c.imports | c.written) & library:
            definers.setdefault(n, set()).add(i)
    # names bound only by a stateless def or class (_pure) are no object through which state is shared: reading one
    # needs its definitions (and, as for every function, reads what its body reads: expanded)
    bound_by: dict[str, list[int]] = {}
    for i, c in enumerate(cells):
        for n in c.defs:
            bound_by.setdefault(n, []).append(i)
    written = set().union(*(c.written for c in cells))
    pure = {n for n, units in bound_by.items() if n not in written and all(n in cells[i].pure for i in units)}

    def expanded(i: int) -> set[str]:
        """What unit i reads, with what every function or class it reads reads when called (stateless or not)."""
        out, todo = set(), list(cells[i].reads)
        while todo:
            n = todo.pop()
            if n in out:
                continue
            out.add(n)
            todo += [m for j in bound_by.get(n, ()) if n in cells[j].functions for m in cells[j].reads]
        return out

    for n in pure:
        definers[n] = set(bound_by[n])
    library |= pure

    def reaching(i: int, n: str) -> frozenset:
        """The units whose binding of n may be the one unit i sees (-1: none, n comes from nowhere earlier)."""
        out = set()
        for j in reversed(bound_by.get(n, [])):
            if j < i:
                out.add(j)
                if n in cells[j].kills:
                    return frozenset(out)
        return frozenset(out | {-1})

    def objects(i: int, names: Iterable[str]) -> set[tuple[str, int]]:
        return {(n, j) for n in set(names) - library for j in reaching(i, n)}

    shared = {RANDOM_STATE, FILES}
    reads = [objects(i, expanded(i)) for i in range(len(cells))]
    # what a unit may change: what it mutates, what the functions it calls read (they may change it), and the
    # random state and the files it touches
    muts = [objects(i, c.mutated | (expanded(i) - c.reads) | (c.reads & shared)) |
            {(n, j) for n, j in objects(i, c.iterated) if j < 0 or n not in cells[j].containers}
            for i, c in enumerate(cells)]
    defs = [{(n, i) for n in c.defs - library} for i, c in enumerate(cells)]
    # objects tied together (an alias, a container, a call given both): one component
    parent: dict = {}

    def find(x):
        parent.setdefault(x, x)
        while parent[x] != x:
            parent[x] = parent[parent[x]]
            x = parent[x]
        return x

    for i, c in enumerate(cells):
        group = list(defs[i] | muts[i] | objects(i, c.linked))
        for x in group[1:]:
            parent[find(x)] = find(group[0])
    while True:
        needed = set().union(*(reads[k] for k in keep))
        roots = {find(x) for x in needed}
        more = set()
        for i in range(last + 1):
            if i in keep:
                for n in expanded(i) & library:
                    for j in definers.get(n, ()):
                        if j < i and j not in keep:
                            more.add(j)
                            why.setdefault(j, f"binds or writes {n}, read by unit {i}")
                continue
            if defs[i] & needed:
                more.add(i)
                why.setdefault(i, f"binds {sorted(n for n, _ in defs[i] & needed)}, which the slice reads")
            elif any(find(x) in roots for x in muts[i]):
                more.add(i)
                why.setdefault(i, f"may change {sorted(n for n, j in muts[i] if find((n, j)) in roots)}, which "
                                  f"the slice uses")
        if not more - keep:
            return keep
        keep |= more


def slice_notebook(path: Path, exercise_ids: Iterable[str]) -> None:
    """Rewrite the notebook at `path` (a run's own copy) to what the public checks of `exercise_ids` need
    (public_slice over its CHECK cells of those exercises): the code cells up to the last of them, each whole,
    emptied or with its unneeded statements blanked, every cell keeping its place (nbval's 'Cell N' and the
    messages' cell numbers are the notebook's). A notebook with none of their check cells is left as it is."""
    from .run import check_cells

    ids = set(exercise_ids)
    targets = [i for i, tagged in check_cells(path).items() if ids & set(tagged)]
    if not targets:
        return
    nb = json.loads(path.read_text(encoding="utf-8"))
    code = [c for c in nb["cells"] if c["cell_type"] == "code"]
    sources = public_slice(["".join(c["source"]) for c in code], targets)
    last = code[max(targets)]
    cells = []
    for cell in nb["cells"]:
        cells.append(cell)
        if cell is last:
            break
    for i, cell in enumerate(c for c in cells if c["cell_type"] == "code"):
        cell["source"] = sources[i].splitlines(keepends=True)
    nb["cells"] = cells
    path.write_text(json.dumps(nb, indent=1, ensure_ascii=False) + "\n", encoding="utf-8")


def explain(path: Path, exercise_ids: Iterable[str]) -> list[str]:
    """Why each statement of the notebook at `path` is in the slice of the public checks of `exercise_ids`, one line
    each ("cell <code-cell index> lines <a>-<b>: <reason>"): for a notebook's author shortening a check's slice."""
    from .run import check_cells

    ids = set(exercise_ids)
    targets = [i for i, tagged in check_cells(path).items() if ids & set(tagged)]
    code = [c for c in json.loads(path.read_text(encoding="utf-8"))["cells"] if c["cell_type"] == "code"]
    lines: list[str] = []
    public_slice(["".join(c["source"]) for c in code], targets, lines)
    return lines


if __name__ == "__main__":        # python -m armlab_course.grading.slicing NOTEBOOK EXERCISE...
    import sys

    if len(sys.argv) < 3:
        sys.exit("usage: python -m armlab_course.grading.slicing NOTEBOOK.ipynb EXERCISE [EXERCISE...]")
    print("\n".join(explain(Path(sys.argv[1]), sys.argv[2:])))
