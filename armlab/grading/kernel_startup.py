"""IPython startup file of the grader's notebook kernels (run.py copies it into the work tree's own IPYTHONDIR, so
the instructor's or the student's ~/.ipython never enters): caps what the kernel writes to stdout and stderr, each
write at WRITE_LIMIT characters and the whole run at TOTAL_LIMIT, so that a cell printing hundreds of MB sends
only a little to nbval (its output comparison fails anyway). IPython's copy of every cell's stream output into its
history (InteractiveShell._tee, IPython 9) is switched off too: it would keep each whole write in memory."""

import contextlib
import sys

WRITE_LIMIT = 100_000
TOTAL_LIMIT = 20_000_000


def _capped(stream, left=[TOTAL_LIMIT]):  # noqa: B006 (one budget shared by stdout and stderr)
    write = stream.write

    def capped(text):
        if not isinstance(text, str):
            return write(text)
        n = len(text)
        if left[0] <= 0:
            return n
        kept = text[:min(WRITE_LIMIT, left[0])]
        left[0] -= len(kept)
        write(kept if len(kept) == n else kept + f"\n[... {n - len(kept)} characters cut by the grader]\n")
        return n

    stream.write = capped


for _stream in (sys.stdout, sys.stderr):
    _capped(_stream)
_shell = get_ipython()  # noqa: F821 (a startup file runs in the kernel's namespace)
if hasattr(_shell, "_tee"):
    _shell._tee = lambda channel: contextlib.nullcontext()
