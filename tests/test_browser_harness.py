"""The browser tests' side channel to a kernel (tests/browser.py) holds on a loaded machine.

The cause of issue 26's "Kernel died before replying to kernel_info": a client made from a connection file, connected
while the kernel is still starting (JupyterLab lists a kernel as soon as it has launched the process), judged the
kernel by jupyter_client's heartbeat, which gives it 1 s to answer: a kernel that needs longer to start was called
dead. The harness waits for the kernel_info reply instead and asks the kernel's owner whether it died.
"""

from __future__ import annotations

import sys
from pathlib import Path

import pytest
from jupyter_client import BlockingKernelClient, KernelManager

sys.path.insert(0, str(Path(__file__).parent))
import browser  # noqa: E402


@pytest.fixture
def starting_kernel():
    """A kernel whose process was just launched (start_kernel returns before the kernel is up)."""
    manager = KernelManager(kernel_name="python3")
    manager.start_kernel()
    yield manager
    manager.shutdown_kernel(now=True)


def client_of(manager: KernelManager, hb: bool) -> BlockingKernelClient:
    client = BlockingKernelClient(connection_file=manager.connection_file)
    client.load_connection_file()
    client.start_channels(hb=hb)
    return client


def test_a_starting_kernel_is_waited_for_not_called_dead(starting_kernel):
    client = client_of(starting_kernel, hb=False)
    try:
        browser.wait_for_kernel_info(client, lambda: "" if starting_kernel.is_alive() else "its process is gone", 300)
        msg_id = client.execute("x = 6 * 7", user_expressions={"x": "x"})
        reply = client.get_shell_msg(timeout=120)          # the reply on the shell channel: no iopub subscription
        while reply["parent_header"].get("msg_id") != msg_id:   # to race on a loaded machine
            reply = client.get_shell_msg(timeout=120)
        assert reply["content"]["user_expressions"]["x"]["data"]["text/plain"] == "42"
    finally:
        client.stop_channels()


def test_a_kernel_that_died_is_reported_with_the_reason(starting_kernel):
    client = client_of(starting_kernel, hb=False)
    starting_kernel.shutdown_kernel(now=True)
    try:
        with pytest.raises(RuntimeError, match="died before replying to kernel_info: its process is gone"):
            browser.wait_for_kernel_info(client, lambda: "" if starting_kernel.is_alive() else "its process is gone",
                                         300)
    finally:
        client.stop_channels()
