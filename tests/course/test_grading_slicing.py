"""The public checks' slice (armlab_course.grading.slicing): the cells a check cell needs, kept conservatively -- a
cell that may change what the check reads is never left out -- and the rest left out, so that the grader and the
self-check run a check in seconds with the verdict of the whole notebook. Pure Python: no notebook runs here (the
self-check's tests run sliced notebooks against the grader's)."""

from __future__ import annotations

import json

import pytest

from armlab_course.grading.slicing import cell_names, explain, public_slice, slice_notebook


def kept(cells: list[str], target: int | None = None) -> list[int]:
    """The cells of `cells` the last (or `target`) needs, each kept whole or in part."""
    target = len(cells) - 1 if target is None else target
    return sorted(i for i, s in public_slice(cells, [target]).items() if s.strip())


@pytest.mark.parametrize("cells, want", [
    # a definition the check reads, and not the unrelated cell
    (["a = 1", "b = 2", "assert a == 1"], [0, 2]),
    # a cell that only reads a name may mutate its object
    (["a = []", "a.append(1)", "b = 2", "assert a == [1]"], [0, 1, 3]),
    # an alias: the check reads b, a later cell mutates it through a
    (["a = make()", "b = a.child", "a.child.x = 1", "assert b.x == 1"], [0, 1, 2, 3]),
    # a binding that always runs hides the earlier one; a conditional one does not
    (["x = 1", "x = 2", "assert x == 2"], [1, 2]),
    (["x = 1", "if c:\n    x = 2", "assert x"], [0, 1, 2]),
    # a loop's target is fresh inside the loop only
    (["b = 5", "for b in []:\n    pass", "assert b"], [0, 1, 2]),
    # what cannot be analysed joins with every cell before it
    (["a = 1", "%time b = 2", "c = 3", "assert c"], [0, 1, 2, 3]),
    (["a = 1", "exec('a = 2')", "c = 3", "assert c"], [0, 1, 2, 3]),
    (["a = 1", "def f():\n    global a\n    a = 2", "c = 3", "assert c"], [0, 1, 2, 3]),
    (["a = 1", "from os.path import *", "c = 3", "assert c"], [0, 1, 2, 3]),
    (["a = 1", "globals()['c'] = 2", "c = 3", "assert c"], [0, 1, 2, 3]),
    # the global random state is one shared object; a generator of one's own is not
    (["import numpy as np", "np.random.seed(0)", "x = np.random.rand()", "y = 1", "assert np.random.rand() < 1"],
     [0, 1, 2, 4]),
    (["import numpy as np", "r = np.random.default_rng(0)", "z = np.random.default_rng(1).random()",
      "assert r.random() < 1"], [0, 1, 3]),
    (["import random", "random.seed(1)", "assert random.random() < 1"], [0, 1, 2]),
    # a library read by a cell does not join it; a cell that writes into the library does
    (["import numpy as np", "a = np.zeros(3)", "np.ones(2)", "assert a.sum() == 0"], [0, 1, 3]),
    (["import numpy as np", "np.set_printoptions(precision=1)", "print(np.pi)"], [0, 1, 2]),
    (["import numpy as np", "np.pi = 3", "assert np.pi == 3"], [0, 1, 2]),
    # a stateless function: calling it elsewhere is no shared state; what its body reads is
    (["def f(x):\n    return x + 1", "f(5)", "assert f(1) == 2"], [0, 2]),
    (["def f():\n    return g", "g = []", "f().append(1)", "assert f() == [1]"], [0, 1, 2, 3]),
    # a function with a mutable default or a decorator holds state
    (["def f(acc=[]):\n    acc.append(1)\n    return acc", "f()", "assert f() == [1, 1]"], [0, 1, 2]),
    (["import functools", "@functools.cache\ndef f():\n    return []", "f().append(1)", "assert f() == [1]"],
     [0, 1, 2, 3]),
    # files are one shared object
    (["open('x', 'w').write('1')", "y = 2", "assert open('x').read() == '1'"], [0, 2]),
    # a name that comes from nowhere earlier still ties the cells that use it
    (["undefined_here.append(1)", "assert undefined_here"], [0, 1]),
    # a cell that only reads an object (a pure builtin, numpy, a plain expression) does not join; one that hands it
    # to a call that may change it does
    (["a = [1]", "print(len(a), a[0] + 1, np.mean(a))", "assert a == [1]"], [0, 2]),
    (["a = [1]", "touch(a)", "assert a == [1]"], [0, 1, 2]),
    (["a = [1]", "b = {'k': a}", "b['k'].append(2)", "assert a == [1]"], [0, 1, 2, 3]),
    # iterating over a fresh list uses nothing up; over anything else (a generator) it may
    (["a = [1, 2]", "for x in a:\n    print(x)", "assert sum(a) == 3"], [0, 2]),
    (["a = (x for x in [1, 2])", "for x in a:\n    print(x)", "assert sum(a) == 0"], [0, 1, 2]),
    # a check cell after the target never joins
    (["a = 1", "assert a", "a = 2"], [0, 1]),
])
def test_the_slice_keeps_every_cell_that_may_change_the_check(cells, want):
    target = 1 if cells == ["a = 1", "assert a", "a = 2"] else None
    assert kept(cells, target) == want


def test_a_cell_is_cut_to_the_statements_the_check_needs_keeping_its_line_numbers():
    cells = ["import numpy as np\nbig = run_the_simulator()\n\n\ndef f():\n    return np.ones(2)\n",
             "assert f().sum() == 2"]
    sliced = public_slice(cells, [1])
    assert sliced[1] == cells[1]
    lines = sliced[0].splitlines()
    assert len(lines) == len(cells[0].splitlines()) and lines[1] == "" and "def f():" == lines[4], sliced[0]
    # the cut cell still runs the statement the check needs, and the statement left out does not come back
    assert "run_the_simulator" not in sliced[0] and "import numpy as np" in sliced[0]


def test_names_local_to_a_function_are_not_the_notebooks():
    names = cell_names("def f(x):\n    y = x + z\n    return [w for w in y]\n")
    assert names.defs == {"f"} and "z" in names.reads and not {"x", "y", "w"} & names.reads


def test_slice_notebook_keeps_every_cell_in_its_place(tmp_path):
    code = ["import numpy as np\nslow = simulate()", "a = np.ones(2)", "slow.plot()",
            "# CHECK ex.one\nassert a.sum() == 2", "after = 1"]
    cells = [{"cell_type": "markdown", "metadata": {}, "source": ["# title"]}]
    cells += [{"cell_type": "code", "metadata": {}, "source": s.splitlines(keepends=True), "outputs": [],
               "execution_count": None} for s in code]
    path = tmp_path / "nb.ipynb"
    path.write_text(json.dumps({"cells": cells, "metadata": {}, "nbformat": 4, "nbformat_minor": 5}))
    slice_notebook(path, ["ex.one"])
    out = [c for c in json.loads(path.read_text())["cells"] if c["cell_type"] == "code"]
    assert ["".join(c["source"]) for c in out] == ["import numpy as np\n\n", "a = np.ones(2)", "", code[3]]
    slice_notebook(path, ["ex.other"])           # no check cell of it: left as it is
    assert [c for c in json.loads(path.read_text())["cells"] if c["cell_type"] == "code"] == out


def test_explain_says_why_each_statement_is_kept(tmp_path):
    code = ["x = 1\ny = 2", "# CHECK ex.one\nassert x == 1"]
    cells = [{"cell_type": "code", "metadata": {}, "source": s, "outputs": [], "execution_count": None} for s in code]
    path = tmp_path / "nb.ipynb"
    path.write_text(json.dumps({"cells": cells, "metadata": {}, "nbformat": 4, "nbformat_minor": 5}))
    assert explain(path, ["ex.one"]) == ["cell 0 lines 1-1: binds ['x'], which the slice reads",
                                         "cell 1 lines 1-2: a check cell"]
