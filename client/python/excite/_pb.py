"""The generated stubs (excite.v1.*), imported in one place.

Nothing is generated here: an installed package carries the stubs its build
generated; a checkout generates them once with ``client/python/excite/codegen.py``.
Missing stubs are an ImportError that says so. In a checkout whose stubs were
generated in place (they have a stamp file) and whose protos changed since, a
warning says to regenerate.
"""

from __future__ import annotations

import importlib.util
import os
import warnings

_HELP = (
    "excite: the generated stubs (excite/v1/*_pb2.py) are missing. Install the "
    "package (`pip install client/python` generates them at build time), or, to use "
    "client/python in place, generate them once: "
    "`/usr/bin/python3 client/python/excite/codegen.py`"
)

try:
    from excite.v1 import exploration_service_pb2 as pb
    from excite.v1 import exploration_service_pb2_grpc as pb_grpc
    from excite.v1 import session_config_pb2 as config_pb
    from excite.v1 import sim_config_pb2 as sim_pb
except ModuleNotFoundError as error:  # pragma: no cover - depends on the tree
    if not (error.name or "").startswith("excite.v1"):
        raise
    raise ImportError(_HELP) from error


def _warn_if_stale() -> None:
    """In a checkout: warns if proto/ changed after the stubs were generated in place
    (a few small files hashed). Stubs built by setup.py have no stamp: nothing to do
    in an installed package."""
    stamp = os.path.join(os.path.dirname(os.path.abspath(pb.__file__)), ".proto-sha256")
    if not os.path.isfile(stamp):
        return
    # codegen.py loaded by path under a private name, not as excite.codegen (which
    # would upset `python3 -m excite.codegen`, which imports this module first).
    spec = importlib.util.spec_from_file_location(
        "_excite_codegen_check", os.path.join(os.path.dirname(__file__), "codegen.py"))
    assert spec is not None and spec.loader is not None
    codegen = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(codegen)
    root = codegen.proto_dir()
    if root is None:
        return
    with open(stamp) as f:
        if f.read().strip() != codegen.digest(root):
            warnings.warn(
                "excite: proto/ changed since the stubs in excite/v1 were generated; "
                "regenerate them: /usr/bin/python3 client/python/excite/codegen.py",
                stacklevel=2)


try:
    _warn_if_stale()
except OSError:  # pragma: no cover - unreadable files: no warning
    pass

__all__ = ["pb", "pb_grpc", "config_pb", "sim_pb"]
