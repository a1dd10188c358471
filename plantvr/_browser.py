"""Headless Debian Chromium for browser tests and benchmarks (playwright cannot download its own browser here)."""
from __future__ import annotations

import os
import signal
import subprocess

__all__ = ["CHROMIUM", "CHROMIUM_ARGS", "launch_chromium", "stop_process_group"]

CHROMIUM = "/usr/bin/chromium"
#: As root on a closed network: no sandbox, no GPU, no background connections that would be refused.
CHROMIUM_ARGS = ["--headless", "--no-sandbox", "--disable-gpu", "--disable-background-networking",
                 "--disable-component-update", "--disable-sync"]


def launch_chromium(playwright, **kwargs):
    """Launch Debian's chromium through a ``sync_playwright()`` handle."""
    return playwright.chromium.launch(executable_path=CHROMIUM, args=CHROMIUM_ARGS, **kwargs)


def stop_process_group(proc: subprocess.Popen) -> None:
    """Terminate a server started with ``start_new_session=True`` and everything it spawned (kernels)."""
    try:
        os.killpg(proc.pid, signal.SIGTERM)
        proc.wait(10)
    except (ProcessLookupError, subprocess.TimeoutExpired):
        try:
            os.killpg(proc.pid, signal.SIGKILL)
        except ProcessLookupError:
            pass
        proc.wait(5)
