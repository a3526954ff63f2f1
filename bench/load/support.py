"""What the load benchmarks share: an excite-server started on loopback with a fresh
SQLite data directory (the embedded default), stopped at the end of the `with`
block, and pendulum transitions to feed it.

    with LocalServer(binary, "--planner_workers=2") as server:
        client = Client(server.address)
"""
import os
import re
import shutil
import subprocess
import sys
import tempfile

import numpy as np

sys.path.insert(0, os.path.join(os.path.dirname(__file__), "..", "..", "client", "python"))


class LocalServer:
    def __init__(self, binary, *flags):
        self.data_dir = tempfile.mkdtemp(prefix="excite-bench-")
        self.process = subprocess.Popen(
            [binary, "--listen=127.0.0.1:0", f"--data_dir={self.data_dir}",
             "--log_level=warning", *flags], stdout=subprocess.PIPE, text=True)
        line = self.process.stdout.readline().strip()  # "... listening on HOST:PORT"
        if not line:
            self.stop()
            raise RuntimeError(f"{binary} {' '.join(flags)} did not start")
        self.address = "127.0.0.1:" + line.rsplit(":", 1)[1]

    def cpu_seconds(self):
        """User + system CPU time of the server process so far (Linux /proc)."""
        with open(f"/proc/{self.process.pid}/stat") as f:
            fields = f.read().rsplit(")", 1)[1].split()
        return (int(fields[11]) + int(fields[12])) / os.sysconf("SC_CLK_TCK")

    def status_mib(self, field):
        """A memory line of the server's /proc status in MiB: "VmRSS", "VmHWM" (peak)."""
        with open(f"/proc/{self.process.pid}/status") as f:
            return int(re.search(field + r":\s+(\d+)", f.read()).group(1)) / 1024

    def stop(self):
        self.process.terminate()
        self.process.wait()
        shutil.rmtree(self.data_dir, ignore_errors=True)

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.stop()


def pendulum_transitions(n, rng, first=0):
    """n transitions (x, u, x_next, sequences) of a pendulum (one explicit Euler step
    of 0.05 s) from states and inputs drawn uniformly, sequences first..first+n-1."""
    x = rng.uniform([-3.1, -8], [3.1, 8], (n, 2))
    u = rng.uniform(-2, 2, (n, 1))
    dt = 0.05
    omega = x[:, 1] + dt * (-9.81 * np.sin(x[:, 0]) + u[:, 0])
    x_next = np.stack([x[:, 0] + dt * omega, omega], axis=1)
    return x, u, x_next, np.arange(first, first + n)
