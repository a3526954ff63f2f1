"""Fixtures: a real excite-server process on a free port with a temporary data dir.

The binary is $EXCITE_SERVER_BIN (ctest sets it to the build's excite-server), else
build/release/server/excite-server. The Python package is client/python, used in
place: its stubs are generated here first if they are missing or older than proto/
(client/python/excite/codegen.py, loaded by path: the package cannot be imported
without them), then client/python goes on sys.path, so plain
`/usr/bin/python3 -m pytest tests/python` works. test_install.py installs it into a
venv instead.
"""

import importlib.util
import os
import pathlib
import re
import signal
import subprocess
import sys
import threading

import pytest

REPO = pathlib.Path(__file__).resolve().parents[2]
CLIENT_DIR = REPO / "client" / "python"


def load_codegen():
    """client/python/excite/codegen.py as a module, without importing excite."""
    spec = importlib.util.spec_from_file_location(
        "excite_codegen_for_tests", CLIENT_DIR / "excite" / "codegen.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


codegen = load_codegen()
codegen.ensure_stubs()
sys.path.insert(0, str(CLIENT_DIR))

import excite  # noqa: E402


class ServerProcess:
    """excite-server as a child process; `address` is HOST:PORT once started."""

    def __init__(self, data_dir, extra_args=()):
        self.binary = os.environ.get(
            "EXCITE_SERVER_BIN", str(REPO / "build" / "release" / "server" / "excite-server"))
        if not os.access(self.binary, os.X_OK):
            pytest.fail(f"excite-server not found at {self.binary} (build first or set "
                        "EXCITE_SERVER_BIN)")
        self.data_dir = data_dir
        self.extra_args = list(extra_args)
        self.process = None
        self.address = None
        self.stderr_lines = []

    def start(self, timeout_s=20):
        self.process = subprocess.Popen(
            [self.binary, "--listen=127.0.0.1:0", f"--data_dir={self.data_dir}",
             "--log_level=warning"] + self.extra_args,
            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
        threading.Thread(target=self._drain_stderr, daemon=True).start()
        line = []
        reader = threading.Thread(target=lambda: line.append(self.process.stdout.readline()))
        reader.start()
        reader.join(timeout_s)
        match = re.fullmatch(r"excite-server listening on (\S+)\n", line[0] if line else "")
        if not match:
            self.process.kill()
            pytest.fail(f"excite-server did not start: {line} {self.stderr_lines}")
        self.address = match.group(1)
        return self

    def _drain_stderr(self):
        for text in self.process.stderr:
            self.stderr_lines.append(text)

    def stop(self, timeout_s=20):
        """SIGTERM; returns the exit code (0 for a clean stop)."""
        if self.process is None or self.process.poll() is not None:
            return None if self.process is None else self.process.returncode
        self.process.send_signal(signal.SIGTERM)
        try:
            return self.process.wait(timeout_s)
        except subprocess.TimeoutExpired:
            self.process.kill()
            self.process.wait()
            return "killed after timeout"


@pytest.fixture(scope="module")
def server(tmp_path_factory):
    proc = ServerProcess(tmp_path_factory.mktemp("excite-data")).start()
    yield proc
    code = proc.stop()
    assert code == 0, f"excite-server exit {code}: {''.join(proc.stderr_lines)}"


@pytest.fixture()
def client(server):
    with excite.Client(server.address, timeout_s=30, plan_timeout_s=60) as c:
        c.wait_for_ready(10)
        yield c
