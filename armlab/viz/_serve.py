"""Entry point of a meshcat server process that dies with its parent: `python -m armlab.viz._serve PARENT_PID`.

meshcat's own launcher leaves the server running when its parent is killed outright (nbval kills kernels that way),
so this wrapper watches the parent and exits as soon as it is gone. Its web server listens on 127.0.0.1 only (meshcat's
own listens on every interface, without a token); its zmq socket is bound to 127.0.0.1 by meshcat. It prints
`zmq_url=...` and `web_url=...` (one line each, like meshcat's server) and then silences stdout so that nobody has to
keep reading the pipe.
"""

from __future__ import annotations

import os
import sys
import threading
import time


def _watch_parent(parent_pid: int, period_s: float = 0.2) -> None:
    while os.getppid() == parent_pid:
        time.sleep(period_s)
    os._exit(0)


LOOPBACK = "127.0.0.1"


def _loopback_bridge():
    """meshcat's ZMQWebSocketBridge whose tornado app listens on LOOPBACK instead of on every interface."""
    import functools

    from meshcat.servers.zmqserver import ZMQWebSocketBridge

    class LoopbackBridge(ZMQWebSocketBridge):
        def make_app(self):
            app = super().make_app()
            app.listen = functools.partial(app.listen, address=LOOPBACK)   # meshcat calls app.listen(port)
            return app

    return LoopbackBridge


def main(argv: list[str]) -> int:
    if len(argv) != 1 or not argv[0].isdigit():
        print("usage: python -m armlab.viz._serve PARENT_PID", file=sys.stderr)
        return 2
    parent_pid = int(argv[0])
    if os.getppid() != parent_pid:  # the parent died before we started
        return 0
    threading.Thread(target=_watch_parent, args=(parent_pid,), daemon=True).start()
    bridge = _loopback_bridge()()
    print(f"zmq_url={bridge.zmq_url}", flush=True)
    print(f"web_url={bridge.web_url}", flush=True)
    devnull = open(os.devnull, "w")  # noqa: SIM115 (lives as long as the process)
    os.dup2(devnull.fileno(), 1)
    sys.stdout = devnull
    bridge.run()
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
