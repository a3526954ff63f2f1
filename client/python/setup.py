"""setuptools hook of pyproject.toml: build_py also generates the gRPC stubs.

The metadata is in pyproject.toml. This only adds a step to build_py: after the
package's own modules are copied into the build tree, excite/codegen.py (loaded by
path: the package cannot be imported before its stubs exist) runs protoc and
grpc_python_plugin on proto/excite/v1/*.proto and writes excite/v1/ there. The
protos are found at ../../proto (this repository's layout) or $EXCITE_PROTO_DIR.
"""

import importlib.util
import os

from setuptools import setup
from setuptools.command.build_py import build_py

HERE = os.path.dirname(os.path.abspath(__file__))


def _codegen():
    spec = importlib.util.spec_from_file_location(
        "_excite_codegen", os.path.join(HERE, "excite", "codegen.py"))
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


class BuildPyWithStubs(build_py):
    """build_py, then the stubs into <build_lib>/excite/v1 (no stamp: an installed
    package is never regenerated or checked against protos)."""

    def run(self):
        super().run()
        out = os.path.join(self.build_lib, "excite", "v1")
        names = _codegen().generate(out_dir=out, stamp=False)
        self.announce(f"excite: generated {len(names)} stub files in {out}", level=2)
        self._stub_outputs = [os.path.join(out, n) for n in names]

    def get_outputs(self, include_bytecode=1):
        return super().get_outputs(include_bytecode) + getattr(self, "_stub_outputs", [])


setup(cmdclass={"build_py": BuildPyWithStubs})
