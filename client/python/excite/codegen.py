"""Generates the Python protobuf and gRPC stubs of excite from proto/.

    /usr/bin/python3 -m excite.codegen          (from client/python)

writes excite/v1/{session_config,sim_config,exploration_service}_pb2.py and
exploration_service_pb2_grpc.py with Debian's protoc and grpc_python_plugin
(packages protobuf-compiler and protobuf-compiler-grpc). The generated modules import
each other as ``excite.v1.*``, which is why they live inside this package.

``import excite`` calls :func:`ensure_stubs`, which regenerates only when the .proto
files changed (a SHA-256 of them is kept next to the stubs), so a checkout never runs
stale stubs. Set EXCITE_PROTO_DIR to use protos from another place.
"""

import fcntl
import hashlib
import os
import shutil
import subprocess
import sys
import tempfile

PACKAGE_DIR = os.path.dirname(os.path.abspath(__file__))
STUB_DIR = os.path.join(PACKAGE_DIR, "v1")
STAMP = os.path.join(STUB_DIR, ".proto-sha256")
PROTO_FILES = (
    "excite/v1/session_config.proto",
    "excite/v1/sim_config.proto",
    "excite/v1/exploration_service.proto",
)


def proto_dir():
    """The directory holding excite/v1/*.proto, or None if there is none."""
    candidates = [
        os.environ.get("EXCITE_PROTO_DIR"),
        # client/python/excite -> repository root/proto
        os.path.join(PACKAGE_DIR, os.pardir, os.pardir, os.pardir, "proto"),
    ]
    for candidate in candidates:
        if candidate and all(
            os.path.isfile(os.path.join(candidate, p)) for p in PROTO_FILES
        ):
            return os.path.normpath(candidate)
    return None


def _digest(root):
    h = hashlib.sha256()
    for p in PROTO_FILES:
        with open(os.path.join(root, p), "rb") as f:
            h.update(p.encode() + b"\0" + f.read() + b"\0")
    return h.hexdigest()


def _stubs_present():
    return os.path.isfile(os.path.join(STUB_DIR, "exploration_service_pb2_grpc.py"))


def _tool(name):
    path = shutil.which(name)
    if path is None:
        raise RuntimeError(
            f"{name} not found: install Debian's protobuf-compiler and "
            "protobuf-compiler-grpc (scripts/setup.sh does)"
        )
    return path


def generate(root=None):
    """Runs protoc on the protos under `root` and installs the stubs atomically."""
    root = root or proto_dir()
    if root is None:
        raise RuntimeError("excite protos not found; set EXCITE_PROTO_DIR")
    protoc = _tool("protoc")
    plugin = _tool("grpc_python_plugin")
    digest = _digest(root)
    with tempfile.TemporaryDirectory(dir=PACKAGE_DIR, prefix=".gen-") as out:
        subprocess.run(
            [
                protoc,
                f"--proto_path={root}",
                f"--python_out={out}",
                f"--grpc_out={out}",
                f"--plugin=protoc-gen-grpc={plugin}",
                *PROTO_FILES,
            ],
            check=True,
        )
        generated = os.path.join(out, "excite", "v1")
        with open(os.path.join(generated, "__init__.py"), "w") as f:
            f.write('"""Generated from proto/excite/v1 by excite.codegen."""\n')
        with open(os.path.join(generated, ".proto-sha256"), "w") as f:
            f.write(digest + "\n")
        os.makedirs(STUB_DIR, exist_ok=True)
        # Modules first, the stamp last: a reader that sees the new stamp sees the
        # new modules.
        names = sorted(os.listdir(generated), key=lambda n: n == ".proto-sha256")
        for name in names:
            os.replace(os.path.join(generated, name), os.path.join(STUB_DIR, name))


def ensure_stubs():
    """Generates the stubs if they are missing or older than the protos."""
    root = proto_dir()
    if root is None:
        if _stubs_present():
            return  # an installed copy without the protos
        raise RuntimeError(
            "excite: no generated stubs and no protos; set EXCITE_PROTO_DIR"
        )
    digest = _digest(root)

    def fresh():
        try:
            with open(STAMP) as f:
                return _stubs_present() and f.read().strip() == digest
        except OSError:
            return False

    if fresh():
        return
    with open(os.path.join(PACKAGE_DIR, ".codegen.lock"), "w") as lock:
        fcntl.flock(lock, fcntl.LOCK_EX)  # one generator at a time
        if not fresh():
            generate(root)


def main():
    generate()
    print(f"stubs written to {STUB_DIR}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
