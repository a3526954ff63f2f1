"""client/python as an installed package: built and installed offline into a venv
over Debian's python3 (--system-site-packages: python3-grpcio, python3-protobuf and
python3-numpy), then used from outside the source tree with a read-only package
directory and no protoc on PATH, against a real excite-server.

The package is built from a copy of client/python and proto/ laid out as in the
repository (so pip writes nothing into the checkout and the copy has no stubs:
the build must generate them). ctest runs this module as its own test,
python_install.
"""

import json
import os
import pathlib
import shutil
import stat
import subprocess
import textwrap

import pytest

from conftest import CLIENT_DIR, REPO

# What the installed package runs: every public call kind, blocking and asyncio.
USER_SCRIPT = textwrap.dedent("""
    import asyncio, json, sys
    import numpy as np
    import excite, excite.aio

    config = {"state_dim": 2, "input_dim": 1, "input_bounds": [[-1, 1]],
              "state_bounds": [[-1, 1], [-1, 1]], "noise": {"variance": 1e-4},
              "kernel": {"fit": True}, "target": "delta", "strategy": "rec",
              "horizon": 3, "seed": 1}
    rng = np.random.default_rng(1)
    x = rng.uniform(-1, 1, (12, 2)); u = rng.uniform(-1, 1, (12, 1))
    y = x + 0.1 * np.hstack([x[:, 1:], u])
    with excite.Client(sys.argv[1]) as client:
        session = client.create_session(config, session_id="installed")
        added = session.add(x, u, y)
        data = session.samples()
        prediction = session.predict(np.hstack([x[:2], u[:2]]))

    async def use_aio():
        async with excite.aio.Client(sys.argv[1]) as client:
            session = await client.session("installed")
            plan = await session.plan([0.0, 0.0])
            await session.delete()
            return plan

    plan = asyncio.run(use_aio())
    print(json.dumps({
        "excite": excite.__file__, "stubs": excite.pb.__file__,
        "added": [added.stored, added.sample_count, added.first_sequence,
                  added.last_sequence],
        "samples_exact": data.states.tobytes() == x.tobytes()
                         and data.next_states.tobytes() == y.tobytes(),
        "prediction_shape": list(prediction.mean.shape),
        "plan_shape": list(plan.inputs.shape),
        "typed": type(added).__name__,
    }))
""")


def _copy_sources(destination):
    """client/python (without generated or built files) and proto/, as laid out in
    the repository."""
    ignore = shutil.ignore_patterns("v1", "build", "*.egg-info", "__pycache__",
                                    ".codegen.lock", ".mypy_cache", ".gen-*")
    shutil.copytree(CLIENT_DIR, destination / "client" / "python", ignore=ignore)
    shutil.copytree(REPO / "proto", destination / "proto")
    return destination / "client" / "python"


def _snapshot(directory):
    return sorted((str(p.relative_to(directory)), p.stat().st_size, p.stat().st_mtime_ns)
                  for p in directory.rglob("*"))


def _set_writable(directory, writable):
    for path in [directory, *directory.rglob("*")]:
        mode = path.stat().st_mode
        mode = (mode | stat.S_IWUSR) if writable else (mode & ~(stat.S_IWUSR | stat.S_IWGRP
                                                              | stat.S_IWOTH))
        path.chmod(mode)


def test_installs_into_a_venv_and_runs_without_protoc_or_sources(server, tmp_path):
    if not pathlib.Path("/usr/bin/python3").exists():
        pytest.skip("needs Debian's /usr/bin/python3")
    source = _copy_sources(tmp_path / "src")
    assert not (source / "excite" / "v1").exists()
    venv = tmp_path / "venv"
    # A clean environment: no PYTHONPATH pointing at the checkout, no user site.
    env = {"PATH": "/usr/bin:/bin", "HOME": str(tmp_path), "PYTHONNOUSERSITE": "1",
           "PIP_DISABLE_PIP_VERSION_CHECK": "1", "PIP_NO_INPUT": "1",
           "LANG": "C.UTF-8"}
    subprocess.run(["/usr/bin/python3", "-m", "venv", "--system-site-packages", str(venv)],
                   check=True, env=env, capture_output=True, timeout=120)
    install = subprocess.run(
        [str(venv / "bin" / "pip"), "install", "--no-index", "--no-build-isolation",
         "--no-cache-dir", str(source)],
        env=env, cwd=tmp_path, capture_output=True, text=True, timeout=300)
    assert install.returncode == 0, install.stdout + install.stderr
    python = venv / "bin" / "python"
    site = subprocess.run(
        [str(python), "-c", "import sysconfig; print(sysconfig.get_paths()['purelib'])"],
        env=env, capture_output=True, text=True, check=True).stdout.strip()
    package = pathlib.Path(site) / "excite"
    assert (package / "py.typed").is_file()
    for name in ("exploration_service_pb2.py", "exploration_service_pb2.pyi",
                 "exploration_service_pb2_grpc.py", "session_config_pb2.py",
                 "sim_config_pb2.py"):
        assert (package / "v1" / name).is_file(), name
    assert not (package / "v1" / ".proto-sha256").exists()  # never checked against protos

    # Use it with no protoc on PATH (only the venv's bin), from a directory outside
    # any source tree, with the package read-only (root ignores the mode bits, so
    # the snapshot below is what proves that nothing is written).
    run_dir = tmp_path / "elsewhere"
    run_dir.mkdir()
    user_env = dict(env, PATH=str(venv / "bin"))
    assert shutil.which("protoc", path=user_env["PATH"]) is None
    assert shutil.which("grpc_python_plugin", path=user_env["PATH"]) is None
    shutil.rmtree(source.parent.parent)  # neither the sources nor the protos remain
    before = _snapshot(package)
    _set_writable(package, False)
    try:
        result = subprocess.run([str(python), "-c", USER_SCRIPT, server.address],
                                env=user_env, cwd=run_dir, capture_output=True, text=True,
                                timeout=120)
    finally:
        _set_writable(package, True)
    assert result.returncode == 0, result.stdout + result.stderr
    assert _snapshot(package) == before  # not even a .pyc (pip compiled them)
    report = json.loads(result.stdout.strip().splitlines()[-1])
    assert pathlib.Path(report["excite"]).parent == package
    assert pathlib.Path(report["stubs"]).parent == package / "v1"
    assert report["added"] == [12, 12, 0, 11] and report["typed"] == "AddResult"
    assert report["samples_exact"] is True
    assert report["prediction_shape"] == [2, 2] and report["plan_shape"] == [3, 1]

    # Every example runs against the installed package (short runs).
    short = {"duffing.py": ["--samples=30", "--every=10", "--horizon=5", "--points=200"],
             "mpc_pendulum.py": ["--samples=30", "--steps=10"]}
    examples = sorted((REPO / "client" / "python" / "examples").glob("*.py"))
    assert [e.name for e in examples] == sorted(short), "give a new example its short run"
    for example in examples:
        run = subprocess.run(
            [str(python), str(example), f"--server={server.address}", *short[example.name]],
            env=user_env, cwd=run_dir, capture_output=True, text=True, timeout=300)
        assert run.returncode == 0, example.name + run.stdout + run.stderr
