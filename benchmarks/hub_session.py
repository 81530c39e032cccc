"""What one student's session costs a hub node: JupyterLab plus a kernel per notebook, every notebook run top to bottom.

    .venv/bin/python benchmarks/hub_session.py [--keep-kernels]

A JupyterLab server is started as a hub's single-user server would be (a base_url, a token), and each lab notebook is
run in a kernel of that server, cell by cell, the way "Run All" does (the notebook's own code, no browser). Per
notebook: wall time, the kernel's peak resident memory (VmHWM) with its children's (a meshcat server, if one is
started) and their CPU seconds. Then the server's own peak memory and CPU. By default each kernel is shut down after
its notebook (a student who closes notebooks); --keep-kernels keeps them all (a student who leaves every tab open,
the worst case), and the peak of the whole session is the sum. Linux only (/proc). Prints one table; nothing is
asserted: a hub's sizing is a reading, not a test.
"""

from __future__ import annotations

import argparse
import json
import os
import sys
import time
import urllib.request
from pathlib import Path
from tempfile import TemporaryDirectory

REPO = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(REPO / "tests"))
import browser  # noqa: E402  (the JupyterLab runner of the browser tests)

PAGE = os.sysconf("SC_PAGE_SIZE")
TICK = os.sysconf("SC_CLK_TCK")


def process_tree(pid: int) -> list[int]:
    out, todo = [], [pid]
    while todo:
        p = todo.pop()
        out.append(p)
        todo.extend(browser._children(p))
    return out


def peak_rss_mb(pid: int) -> float:
    """VmHWM of one process, MB (0 when it is gone)."""
    try:
        for line in Path(f"/proc/{pid}/status").read_text().splitlines():
            if line.startswith("VmHWM:"):
                return int(line.split()[1]) / 1024
    except OSError:
        pass
    return 0.0


def cpu_s(pid: int) -> float:
    """User + system CPU seconds of one process (0 when it is gone)."""
    try:
        fields = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()
    except OSError:
        return 0.0
    return (int(fields[11]) + int(fields[12])) / TICK


def run_notebook(lab: browser.JupyterLab, path: Path, before: set[int]) -> dict:
    from jupyter_client import BlockingKernelClient

    request = urllib.request.Request(f"{lab.url}/api/kernels", method="POST", data=json.dumps({"name": "python3"})
                                     .encode(), headers={"Authorization": f"token {lab.token}",
                                                         "Content-Type": "application/json"})
    with urllib.request.urlopen(request, timeout=120) as response:
        kernel_id = json.loads(response.read())["id"]
    client = BlockingKernelClient(connection_file=str(lab.runtime_dir / f"kernel-{kernel_id}.json"))
    client.load_connection_file()
    client.start_channels(hb=False)
    client.wait_for_ready(timeout=600)
    kernel_pid = sorted(set(browser._children(lab.proc.pid)) - before)
    start = time.monotonic()
    client.execute_interactive(f"import os; os.chdir({str(path.parent)!r})", timeout=60)
    cells = json.loads(path.read_text())["cells"]
    errors = 0
    for cell in cells:
        if cell["cell_type"] == "code":
            reply = client.execute_interactive("".join(cell["source"]), timeout=900, output_hook=lambda msg: None)
            errors += reply["content"]["status"] != "ok"
    wall = time.monotonic() - start
    pids = [p for k in kernel_pid for p in process_tree(k)]
    row = {"notebook": path.stem, "wall_s": wall, "errors": errors,
           "peak_mb": sum(peak_rss_mb(p) for p in pids), "cpu_s": sum(cpu_s(p) for p in pids),
           "processes": len(pids), "kernel_id": kernel_id}
    client.stop_channels()
    return row


def main(argv: list[str]) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--keep-kernels", action="store_true", help="keep every kernel until the end")
    args = parser.parse_args(argv)
    notebooks = sorted((REPO / "notebooks").glob("[0-9][0-9]_*.ipynb"))
    env_zmq = os.environ.pop("ARMLAB_MESHCAT_ZMQ", None)     # each kernel starts its viewer's server, as on a hub
    rows = []
    with TemporaryDirectory(prefix="armlab-hub-") as home, \
            browser.JupyterLab(REPO / "notebooks", home, sys.executable, base_url="/user/student/") as lab:
        for nb in notebooks:
            before = set(browser._children(lab.proc.pid))
            row = run_notebook(lab, nb, before)
            rows.append(row)
            print(f"{row['notebook']:<28} {row['wall_s']:7.1f} s  {row['peak_mb']:7.0f} MB  {row['cpu_s']:7.1f} CPU s"
                  f"  {row['processes']} processes  {row['errors']} errors", flush=True)
            if not args.keep_kernels:
                lab.api(f"/api/kernels/{row['kernel_id']}", method="DELETE", timeout_s=60)
                deadline = time.monotonic() + 30
                while set(browser._children(lab.proc.pid)) - before and time.monotonic() < deadline:
                    time.sleep(0.2)
        server_peak, server_cpu = peak_rss_mb(lab.proc.pid), cpu_s(lab.proc.pid)
    if env_zmq is not None:
        os.environ["ARMLAB_MESHCAT_ZMQ"] = env_zmq
    kernels_peak = max(r["peak_mb"] for r in rows)
    print(f"\n{'notebooks':<28} {sum(r['wall_s'] for r in rows):7.1f} s  (each run top to bottom, one after another)")
    print(f"{'largest kernel (+children)':<28} {kernels_peak:7.0f} MB peak")
    print(f"{'all kernels if kept open':<28} {sum(r['peak_mb'] for r in rows):7.0f} MB (sum of peaks)")
    print(f"{'JupyterLab server':<28} {server_peak:7.0f} MB peak, {server_cpu:.1f} CPU s")
    print(f"{'session, one kernel at a time':<28} {server_peak + kernels_peak:7.0f} MB peak, "
          f"{server_cpu + sum(r['cpu_s'] for r in rows):.1f} CPU s in {sum(r['wall_s'] for r in rows):.0f} s")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
