"""Generates the Python protobuf and gRPC stubs of excite from proto/.

The package never runs this at import time. It runs:

- at build time, from setup.py's build_py (``pip install client/python``, ``pip
  wheel``), which writes the stubs into the build tree, so an installed package
  carries them and needs neither protoc nor the protos;
- by hand in a checkout, to use the package in place (``sys.path`` or
  ``PYTHONPATH=client/python``)::

      /usr/bin/python3 client/python/excite/codegen.py          # from anywhere

  which writes client/python/excite/v1/*_pb2.py, *_pb2.pyi and *_pb2_grpc.py with a
  SHA-256 of the protos next to them (``--check`` says whether they are current;
  tests/python runs :func:`ensure_stubs` before importing the package).

It uses Debian's protoc and grpc_python_plugin (packages protobuf-compiler and
protobuf-compiler-grpc) on every proto/excite/v1/*.proto. The generated modules
import each other as ``excite.v1.*``, which is why they live inside this package.
EXCITE_PROTO_DIR points at the protos when they are not at ../../proto from
client/python.

Standard library only, and no import of the ``excite`` package: setup.py and the
tests load this file by path before any stub exists.
"""

from __future__ import annotations

import argparse
import fcntl
import glob
import hashlib
import os
import shutil
import subprocess
import sys
import tempfile
from typing import List, Optional, Sequence

PACKAGE_DIR = os.path.dirname(os.path.abspath(__file__))
STUB_DIR = os.path.join(PACKAGE_DIR, "v1")
STAMP_NAME = ".proto-sha256"
STAMP = os.path.join(STUB_DIR, STAMP_NAME)
# The service's proto; every other *.proto beside it is generated too.
MAIN_PROTO = "excite/v1/exploration_service.proto"


def proto_dir() -> Optional[str]:
    """The directory holding excite/v1/*.proto (the include root), or None."""
    candidates = [
        os.environ.get("EXCITE_PROTO_DIR"),
        # client/python/excite -> the repository's proto/
        os.path.join(PACKAGE_DIR, os.pardir, os.pardir, os.pardir, "proto"),
    ]
    for candidate in candidates:
        if candidate and os.path.isfile(os.path.join(candidate, MAIN_PROTO)):
            return os.path.normpath(os.path.abspath(candidate))
    return None


def proto_files(root: str) -> List[str]:
    """excite/v1/*.proto under `root`, relative to it, sorted."""
    paths = glob.glob(os.path.join(root, "excite", "v1", "*.proto"))
    return sorted(os.path.relpath(p, root).replace(os.sep, "/") for p in paths)


def digest(root: str) -> str:
    """SHA-256 over the names and contents of the protos under `root`."""
    h = hashlib.sha256()
    for p in proto_files(root):
        with open(os.path.join(root, p), "rb") as f:
            h.update(p.encode() + b"\0" + f.read() + b"\0")
    return h.hexdigest()


def _tool(name: str) -> str:
    path = shutil.which(name)
    if path is None:
        raise RuntimeError(
            f"{name} not found: install Debian's protobuf-compiler and "
            "protobuf-compiler-grpc (scripts/setup.sh does)"
        )
    return path


def _require_root(root: Optional[str]) -> str:
    root = root or proto_dir()
    if root is None:
        raise RuntimeError(
            "excite protos not found (proto/excite/v1 of the repository): set "
            "EXCITE_PROTO_DIR to the directory that holds excite/v1/*.proto"
        )
    return root


def generate(root: Optional[str] = None, out_dir: str = STUB_DIR,
             stamp: bool = True) -> List[str]:
    """Runs protoc on the protos under `root` and moves the stubs into `out_dir`
    (the excite/v1 package directory) atomically, module by module; with `stamp`,
    writes the protos' digest last. Returns the file names written."""
    root = _require_root(root)
    files = proto_files(root)
    protoc = _tool("protoc")
    plugin = _tool("grpc_python_plugin")
    os.makedirs(out_dir, exist_ok=True)
    with tempfile.TemporaryDirectory(dir=out_dir, prefix=".gen-") as tmp:
        subprocess.run(
            [
                protoc,
                f"--proto_path={root}",
                f"--python_out={tmp}",
                f"--pyi_out={tmp}",
                f"--grpc_out={tmp}",
                f"--plugin=protoc-gen-grpc={plugin}",
                *files,
            ],
            check=True,
        )
        generated = os.path.join(tmp, "excite", "v1")
        with open(os.path.join(generated, "__init__.py"), "w") as f:
            f.write('"""Generated from proto/excite/v1 by excite/codegen.py."""\n')
        if stamp:
            with open(os.path.join(generated, STAMP_NAME), "w") as f:
                f.write(digest(root) + "\n")
        # Modules first, the stamp last: a reader that sees the new stamp sees the
        # new modules.
        names = sorted(os.listdir(generated), key=lambda n: (n == STAMP_NAME, n))
        for name in names:
            os.replace(os.path.join(generated, name), os.path.join(out_dir, name))
    return names


def is_current(root: Optional[str] = None, out_dir: str = STUB_DIR) -> bool:
    """Whether the stubs in `out_dir` were generated from the protos as they are."""
    root = _require_root(root)
    try:
        with open(os.path.join(out_dir, STAMP_NAME)) as f:
            stamped = f.read().strip()
    except OSError:
        return False
    present = os.path.isfile(os.path.join(out_dir, "exploration_service_pb2_grpc.py"))
    return present and stamped == digest(root)


def ensure_stubs(root: Optional[str] = None, out_dir: str = STUB_DIR) -> bool:
    """Generates the stubs in place unless they are current (one generator at a
    time, under a lock file). Returns whether it generated."""
    root = _require_root(root)
    if is_current(root, out_dir):
        return False
    os.makedirs(out_dir, exist_ok=True)
    with open(os.path.join(os.path.dirname(out_dir), ".codegen.lock"), "w") as lock:
        fcntl.flock(lock, fcntl.LOCK_EX)
        if is_current(root, out_dir):
            return False
        generate(root, out_dir)
        return True


def main(argv: Optional[Sequence[str]] = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--proto_dir", help="include root holding excite/v1/*.proto "
                        "(default: $EXCITE_PROTO_DIR, else the repository's proto/)")
    parser.add_argument("--out", default=STUB_DIR,
                        help="the excite/v1 directory to write (default: %(default)s)")
    parser.add_argument("--check", action="store_true",
                        help="only say whether the stubs are current (exit 1 if not)")
    parser.add_argument("--if_stale", action="store_true",
                        help="generate only if the stubs are missing or stale")
    args = parser.parse_args(argv)
    if args.check:
        current = is_current(args.proto_dir, args.out)
        print(f"stubs in {args.out} are {'current' if current else 'missing or stale'}")
        return 0 if current else 1
    if args.if_stale:
        generated = ensure_stubs(args.proto_dir, args.out)
        print(f"stubs in {args.out} {'generated' if generated else 'are current'}")
        return 0
    names = generate(args.proto_dir, args.out)
    print(f"{len(names)} files written to {args.out}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
