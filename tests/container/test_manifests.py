"""Static checks of deploy/: the Containerfile, the compose file and the Kubernetes
manifests agree with each other and with the binaries' flags (no cluster needed).

Run: /usr/bin/python3 -m pytest tests/container/test_manifests.py (ctest label deploy).
"""

import json
import os
import pathlib
import re
import socket
import subprocess

import pytest
import yaml

REPO = pathlib.Path(__file__).resolve().parents[2]
DEPLOY = REPO / "deploy"
K8S = DEPLOY / "k8s"
CONTAINERFILE = (DEPLOY / "Containerfile").read_text()
PORT = 50051
UID = 10001
DATA_DIR = "/var/lib/excite"
CONFIG_DIR = "/usr/local/share/excite/configs/"


def server_flags():
    """Names of excite-server's flags, from server/main.cc."""
    names = re.findall(r"ABSL_FLAG\(\s*[\w:]+\s*,\s*(\w+)\s*,", (REPO / "server" / "main.cc").read_text())
    assert "listen" in names and "data_dir" in names, names
    return set(names)


def image_env_flags():
    """The flags the image's command reads from FLAGS_<name> (--tryfromenv)."""
    match = re.search(r'CMD \["excite-server", "--tryfromenv=([\w,]+)"\]', CONTAINERFILE)
    assert match, "the image's CMD must run excite-server --tryfromenv=..."
    return set(match.group(1).split(","))


def k8s_documents():
    kustomization = yaml.safe_load((K8S / "kustomization.yaml").read_text())
    docs = []
    for name in kustomization["resources"]:
        docs += [d for d in yaml.safe_load_all((K8S / name).read_text()) if d]
    return kustomization, docs


def one(docs, kind, name=None):
    found = [d for d in docs if d["kind"] == kind and (name is None or d["metadata"]["name"] == name)]
    assert len(found) == 1, f"want one {kind} {name or ''}, found {len(found)}"
    return found[0]


def flag_value(args, flag):
    for a in args:
        if a.startswith(f"--{flag}="):
            return a.split("=", 1)[1]
    return None


# --- Containerfile -----------------------------------------------------------------

def test_containerfile_shape():
    assert re.search(r"^ARG BASE=debian:bookworm-slim$", CONTAINERFILE, re.M)
    assert re.search(r"^FROM \$\{BASE\} AS build$", CONTAINERFILE, re.M)
    assert re.search(r"^FROM \$\{BASE\} AS runtime$", CONTAINERFILE, re.M)
    runtime = CONTAINERFILE.split("AS runtime", 1)[1]
    assert re.search(rf"^USER {UID}:{UID}$", runtime, re.M)
    assert re.search(rf"^EXPOSE {PORT}$", runtime, re.M)
    assert f'VOLUME ["{DATA_DIR}"]' in runtime
    assert f"FLAGS_data_dir={DATA_DIR}" in runtime
    assert f"FLAGS_listen=0.0.0.0:{PORT}" in runtime
    assert re.search(rf'HEALTHCHECK .*\n\s+CMD \["excite-health", "--server=127.0.0.1:{PORT}"', runtime)
    # The runtime stage installs packages, never builds: no -dev packages there.
    assert "-dev" not in runtime and "cmake" not in runtime
    assert "-DEXCITE_BUILD_TESTS=OFF" in CONTAINERFILE and "-DEXCITE_BUILD_BENCH=OFF" in CONTAINERFILE


def test_every_server_flag_can_come_from_the_environment():
    missing = server_flags() - image_env_flags()
    assert not missing, f"add these to the Containerfile's --tryfromenv list: {sorted(missing)}"


def test_build_context_leaves_out_build_trees():
    ignore = (REPO / ".dockerignore").read_text().split("\n")
    assert "*" in ignore  # allow-list: everything else (build*/, .git, results/) stays out
    copied = set(re.findall(r"^COPY (?!--from)(\S+)", CONTAINERFILE, re.M))
    for path in copied:
        assert f"!{path}" in ignore or f"!{path}/" in ignore, f"{path} copied but ignored"


# --- compose ------------------------------------------------------------------------

def test_compose_stack():
    compose = yaml.safe_load((DEPLOY / "compose.yaml").read_text())
    services = compose["services"]
    server = services["server"]
    assert server["build"]["dockerfile"] == "deploy/Containerfile"
    assert (DEPLOY / server["build"]["context"] / server["build"]["dockerfile"]).is_file()
    assert f"excite-data:{DATA_DIR}" in server["volumes"]
    assert "excite-data" in compose["volumes"]
    assert server["healthcheck"]["test"][1] == "excite-health"
    assert server["read_only"] is True
    assert any(p.endswith(f":{PORT}") for p in server["ports"])
    assert set(server.get("environment", {})) <= {f"FLAGS_{f}" for f in image_env_flags()}

    plants = {name: s for name, s in services.items() if name != "server"}
    assert plants, "at least one plant client"
    for name, plant in plants.items():
        command = plant["command"]
        assert command[0] == "excite-sim", name
        assert flag_value(command, "server") == f"server:{PORT}", name
        config = flag_value(command, "config")
        assert config.startswith(CONFIG_DIR), name
        assert (REPO / "sim" / "configs" / config[len(CONFIG_DIR):]).is_file(), config
        assert plant["image"] == server["image"], name
        assert "server" in plant["depends_on"], name
        summary = flag_value(command, "summary")
        assert any(v.split(":")[1] == str(pathlib.PurePath(summary).parent)
                   for v in plant["volumes"]), f"{name}: summary not on a volume"
    summaries = [flag_value(p["command"], "summary") for p in plants.values()]
    assert len(set(summaries)) == len(summaries), "plants overwrite each other's summary"


# --- Kubernetes ---------------------------------------------------------------------

def secret_file(path, mounts, volumes):
    """(Secret name, key) of the file at `path` inside a container, or None."""
    directory, name = path.rsplit("/", 1)
    volume = volumes.get(mounts.get(directory))
    if volume is None or "secret" not in volume:
        return None
    items = {i["path"]: i["key"] for i in volume["secret"].get("items", [])}
    return volume["secret"]["secretName"], (items.get(name) if items else name)


def test_secrets_come_from_the_generator_and_make_secrets_makes_its_files(tmp_path):
    kustomization, _ = k8s_documents()
    generated = {g["name"]: g for g in kustomization["secretGenerator"]}
    assert set(generated) == {"excite-auth", "excite-tls"}
    keys = {name: dict(f.split("=", 1) for f in g["files"]) for name, g in generated.items()}
    assert set(keys["excite-tls"]) == {"tls.crt", "tls.key", "ca.crt"}
    assert set(keys["excite-auth"]) == {"token"}
    # The script writes exactly the files the generator reads, and never overwrites.
    out = tmp_path / "secrets"
    subprocess.run(["bash", str(K8S / "make-secrets.sh"), "ns1", str(out)], check=True,
                   capture_output=True)
    for files in keys.values():
        for source in files.values():
            assert source.startswith("secrets/")
            assert (out / source[len("secrets/"):]).stat().st_size > 0, source
    assert (out / "tls.key").stat().st_mode & 0o077 == 0
    again = subprocess.run(["bash", str(K8S / "make-secrets.sh"), "ns1", str(out)],
                           capture_output=True, text=True)
    assert again.returncode != 0 and "already holds secrets" in again.stderr
    assert "/deploy/k8s/secrets/" in (REPO / ".gitignore").read_text().split()


def test_kustomization_lists_existing_files_and_names_the_image():
    kustomization, docs = k8s_documents()
    assert kustomization["kind"] == "Kustomization"
    image_names = {i["name"] for i in kustomization["images"]}
    for doc in docs:
        pod = doc["spec"].get("template", {}).get("spec")
        if pod:
            for c in pod.get("containers", []) + pod.get("initContainers", []):
                assert c["image"] in image_names, (doc["metadata"]["name"], c["image"])


def test_statefulset():
    _, docs = k8s_documents()
    sts = one(docs, "StatefulSet")
    spec = sts["spec"]
    assert spec["replicas"] == 1  # see docs/deployment.md, "Several replicas"
    pod = spec["template"]["spec"]
    labels = spec["template"]["metadata"]["labels"]
    assert spec["selector"]["matchLabels"].items() <= labels.items()

    security = pod["securityContext"]
    assert security["runAsNonRoot"] is True
    assert security["runAsUser"] == UID and security["fsGroup"] == UID

    (container,) = pod["containers"]
    assert container["securityContext"]["readOnlyRootFilesystem"] is True
    assert container["securityContext"]["allowPrivilegeEscalation"] is False
    assert container["securityContext"]["capabilities"]["drop"] == ["ALL"]
    assert {"name": "grpc", "containerPort": PORT, "protocol": "TCP"} in container["ports"]
    # Probes: excite-health over TLS on the container port, trusting the CA of the
    # mounted TLS Secret (the kubelet's own gRPC probe speaks plaintext only).
    mounts = {m["mountPath"]: m["name"] for m in container["volumeMounts"]}
    volumes = {v["name"]: v for v in pod["volumes"]}
    for probe in ("livenessProbe", "readinessProbe", "startupProbe"):
        command = container[probe]["exec"]["command"]
        assert command[0] == "excite-health", probe
        assert flag_value(command, "server") == f"127.0.0.1:{PORT}", probe
        assert secret_file(flag_value(command, "tls_ca"), mounts, volumes) == ("excite-tls", "ca.crt")
    for kind in ("requests", "limits"):
        assert {"cpu", "memory"} <= set(container["resources"][kind]), kind

    env = {e["name"]: e["value"] for e in container["env"]}
    assert {n[len("FLAGS_"):] for n in env} <= image_env_flags()
    assert env["FLAGS_data_dir"] == DATA_DIR and env["FLAGS_listen"].endswith(f":{PORT}")
    # TLS and the token from the generated Secrets, never a literal in the manifest.
    assert secret_file(env["FLAGS_tls_cert"], mounts, volumes) == ("excite-tls", "tls.crt")
    assert secret_file(env["FLAGS_tls_key"], mounts, volumes) == ("excite-tls", "tls.key")
    assert secret_file(env["FLAGS_auth_token_file"], mounts, volumes) == ("excite-auth", "token")
    assert not any("TOKEN" in e["name"] for e in container["env"])
    # Metrics: the port Prometheus is told about is the one the server listens on.
    metrics_port = int(env["FLAGS_metrics_listen"].rsplit(":", 1)[1])
    assert {"name": "metrics", "containerPort": metrics_port, "protocol": "TCP"} in container["ports"]
    annotations = spec["template"]["metadata"]["annotations"]
    assert annotations["prometheus.io/scrape"] == "true"
    assert annotations["prometheus.io/port"] == str(metrics_port)
    assert annotations["prometheus.io/path"] == "/metrics"
    # The memory budget is three quarters of the container's memory limit (the
    # server's own default from the cgroup, spelled out): the rest is the process.
    limit = container["resources"]["limits"]["memory"]
    assert limit.endswith("Gi") or limit.endswith("Mi"), limit
    limit_mib = int(limit[:-2]) * (1024 if limit.endswith("Gi") else 1)
    assert int(env["FLAGS_memory_budget_mb"]) == limit_mib * 3 // 4
    (claim,) = spec["volumeClaimTemplates"]
    assert mounts[DATA_DIR] == claim["metadata"]["name"]
    assert "/tmp" in mounts  # writable scratch next to the read-only root
    assert pod["terminationGracePeriodSeconds"] > 5  # the server drains for 5 s


def test_services_select_the_server_pods():
    _, docs = k8s_documents()
    sts = one(docs, "StatefulSet")
    labels = sts["spec"]["template"]["metadata"]["labels"]
    headless = one(docs, "Service", sts["spec"]["serviceName"])
    assert headless["spec"]["clusterIP"] == "None"
    for service in (headless, one(docs, "Service", "excite")):
        assert service["spec"]["selector"].items() <= labels.items()
        (port,) = service["spec"]["ports"]
        assert port["port"] == PORT and port["targetPort"] == "grpc"


def test_plant_job():
    _, docs = k8s_documents()
    job = one(docs, "Job")
    pod = job["spec"]["template"]["spec"]
    assert pod["restartPolicy"] == "Never"
    assert pod["securityContext"]["runAsNonRoot"] is True
    (sim,) = pod["containers"]
    assert sim["command"][0] == "excite-sim"
    host, port = flag_value(sim["command"], "server").split(":")
    one(docs, "Service", host)
    assert int(port) == PORT
    config = flag_value(sim["command"], "config")
    assert (REPO / "sim" / "configs" / config[len(CONFIG_DIR):]).is_file()
    (wait,) = pod["initContainers"]
    assert wait["command"][0] == "excite-health"
    assert flag_value(wait["command"], "server") == f"{host}:{PORT}"
    # Both trust the server's CA and only that: the plant's pod never gets its key.
    volumes = {v["name"]: v for v in pod["volumes"]}
    for c in (sim, wait):
        mounts = {m["mountPath"]: m["name"] for m in c["volumeMounts"]}
        assert secret_file(flag_value(c["command"], "tls_ca"), mounts, volumes) == ("excite-tls", "ca.crt")
    for v in volumes.values():
        if v.get("secret", {}).get("secretName") == "excite-tls":
            assert [i["key"] for i in v["secret"]["items"]] == ["ca.crt"]
    (token,) = [e for e in sim["env"] if e["name"] == "EXCITE_AUTH_TOKEN"]
    assert token["valueFrom"]["secretKeyRef"] == {"name": "excite-auth", "key": "token"}
    for c in (sim, wait):
        assert c["securityContext"]["readOnlyRootFilesystem"] is True
        assert {"cpu", "memory"} <= set(c["resources"]["limits"])


@pytest.mark.parametrize("path", sorted(p.name for p in K8S.glob("*.yaml")))
def test_every_manifest_is_listed_in_the_kustomization(path):
    kustomization, _ = k8s_documents()
    assert path == "kustomization.yaml" or path in kustomization["resources"]


# --- The manifests' security settings against the real binaries ----------------------

def free_port():
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


BINARY_ENV = {"excite-server": "EXCITE_SERVER_BIN", "excite-sim": "EXCITE_SIM_BIN",
              "excite": "EXCITE_CLI_BIN", "excite-health": "EXCITE_HEALTH_BIN"}


def binary(name):
    return os.environ[BINARY_ENV[name]]


@pytest.mark.skipif(not all(os.environ.get(v) for v in BINARY_ENV.values()),
                    reason="set " + ", ".join(BINARY_ENV.values()) + " (ctest does)")
def test_server_probe_and_plant_work_with_the_generated_secrets(tmp_path):
    """The StatefulSet's flags, its probe and the Job's commands, run as written but on
    loopback, with make-secrets.sh's files where the Secrets are mounted: TLS verifies
    (the probe dials 127.0.0.1), the token is required, the plant explores."""
    secrets = tmp_path / "secrets"
    subprocess.run(["bash", str(K8S / "make-secrets.sh"), "default", str(secrets)], check=True,
                   capture_output=True)
    _, docs = k8s_documents()
    port = free_port()

    def local(arg):
        """A manifest argument with in-cluster paths and addresses made local."""
        for mount in ("/etc/excite/tls", "/etc/excite/auth"):
            arg = arg.replace(mount, str(secrets))
        arg = arg.replace(CONFIG_DIR, str(REPO / "sim" / "configs") + "/")
        arg = arg.replace("/results/", str(tmp_path) + "/")
        return arg.replace("excite:50051", f"127.0.0.1:{port}").replace(
            "127.0.0.1:50051", f"127.0.0.1:{port}")

    (server,) = one(docs, "StatefulSet")["spec"]["template"]["spec"]["containers"]
    flags = {e["name"][len("FLAGS_"):]: local(e["value"]) for e in server["env"]}
    flags.update(listen=f"127.0.0.1:{port}", data_dir=str(tmp_path / "data"),
                 metrics_listen="127.0.0.1:0")
    log = open(tmp_path / "server.log", "w")
    process = subprocess.Popen([binary("excite-server")] + [f"--{k}={v}" for k, v in flags.items()],
                               stdout=log, stderr=subprocess.STDOUT)
    try:
        probe = [local(a) for a in server["readinessProbe"]["exec"]["command"]]
        probe = [binary(probe[0])] + probe[1:] + ["--wait_s=60"]
        assert subprocess.run(probe, capture_output=True).returncode == 0, (tmp_path / "server.log").read_text()

        token = (secrets / "token").read_text().strip()
        listing = [binary("excite"), f"--server=127.0.0.1:{port}", f"--tls_ca={secrets}/ca.crt",
                   "sessions", "list"]
        without = subprocess.run(listing, capture_output=True, text=True,
                                 env={k: v for k, v in os.environ.items() if k != "EXCITE_AUTH_TOKEN"})
        assert without.returncode != 0 and "UNAUTHENTICATED" in without.stderr, without.stderr
        assert subprocess.run(listing, capture_output=True, env=dict(os.environ, EXCITE_AUTH_TOKEN=token)).returncode == 0

        pod = one(docs, "Job")["spec"]["template"]["spec"]
        (wait,) = pod["initContainers"]
        command = [local(a) for a in wait["command"]]
        assert subprocess.run([binary(command[0])] + command[1:], capture_output=True).returncode == 0
        (sim,) = pod["containers"]
        command = [local(a) for a in sim["command"] if not a.startswith("--samples=")] + ["--samples=4"]
        secret_env = {e["name"]: token for e in sim["env"] if "secretKeyRef" in e.get("valueFrom", {})}
        plant = subprocess.run([binary(command[0])] + command[1:], capture_output=True, text=True,
                               env=dict(os.environ, **secret_env), timeout=120)
        assert plant.returncode == 0, plant.stdout + plant.stderr
        summary = json.loads((tmp_path / "pendulum-rec.json").read_text())
        assert summary["samples"] >= 4, summary
    finally:
        process.terminate()
        process.wait(timeout=30)
        log.close()


# --- Scaled out: compose.scale.yaml, deploy/haproxy, deploy/k8s/scale --------------

SCALE = K8S / "scale"
HAPROXY = DEPLOY / "haproxy"
PROXY_PORT = 50050


def haproxy_lines(path):
    """The configuration's lines without comments and blank lines."""
    lines = []
    for line in path.read_text().split("\n"):
        code = line.split("#", 1)[0].rstrip()
        if code.strip():
            lines.append(code)
    return lines


def test_haproxy_health_check_is_the_generator_s_and_expects_serving():
    request = subprocess.run(["/usr/bin/python3", str(HAPROXY / "grpc_health_check.py")],
                             check=True, capture_output=True, text=True).stdout.strip()
    for config in (HAPROXY / "haproxy.cfg", SCALE / "haproxy.cfg"):
        lines = [l.strip() for l in haproxy_lines(config)]
        assert f"tcp-check send-binary {request}" in lines, config
        assert "tcp-check expect binary 00000000020801" in lines, config  # SERVING
        assert "balance hdr(x-excite-session)" in lines and "hash-type consistent" in lines
    # The header the proxy hashes is the one both clients send.
    assert 'kSessionHeader[] = "x-excite-session"' in (REPO / "client" / "excite_client.h").read_text()
    assert 'SESSION_HEADER = "x-excite-session"' in (
        REPO / "client" / "python" / "excite" / "_common.py").read_text()


def test_kubernetes_haproxy_config_differs_only_in_bind_and_servers():
    def shared(path):
        return [l for l in haproxy_lines(path)
                if not l.strip().startswith(("bind ", "server ", "server-template "))]
    assert shared(HAPROXY / "haproxy.cfg") == shared(SCALE / "haproxy.cfg")
    assert any(l.strip() == f"bind :{PROXY_PORT} proto h2" for l in haproxy_lines(HAPROXY / "haproxy.cfg"))


def test_compose_scale_stack():
    compose = yaml.safe_load((DEPLOY / "compose.scale.yaml").read_text())
    services = compose["services"]
    replicas = {n: s for n, s in services.items() if n.startswith("excite-")}
    assert len(replicas) == 3
    postgres, proxy = services["postgres"], services["proxy"]
    for name, part in (("postgres", postgres), ("proxy", proxy)):
        context = DEPLOY / part["build"]["context"]
        assert (context / part["build"]["dockerfile"]).is_file(), name
    # The HAProxy config names the replicas by their service names and port.
    servers = [l.split()[1:3] for l in haproxy_lines(HAPROXY / "haproxy.cfg") if l.strip().startswith("server ")]
    assert servers == [[n, f"{n}:{PORT}"] for n in sorted(replicas)]
    assert any(p.endswith(f":{PROXY_PORT}") for p in proxy["ports"])
    for name, replica in replicas.items():
        env = replica["environment"]
        store = env["FLAGS_store"]
        assert store.startswith("postgresql://") and ":" not in store.split("@")[0][len("postgresql://"):], \
            f"{name}: no password in the URL"
        assert store.split("@")[1].startswith("postgres:5432/"), name
        assert "PGPASSWORD" in env, f"{name}: the password from the environment"
        assert set(env) - {"PGPASSWORD"} <= {f"FLAGS_{f}" for f in image_env_flags()}, name
        assert replica["image"] == replicas["excite-1"]["image"]
        assert replica["healthcheck"]["test"][1] == "excite-health"
        assert "postgres" in replica["depends_on"]
        assert "FLAGS_replica_id" not in env, "ids must be unique per process: keep the default"
    assert postgres["environment"]["POSTGRES_PASSWORD"] == replicas["excite-1"]["environment"]["PGPASSWORD"]
    plants = {n: s for n, s in services.items() if n not in replicas and n not in ("postgres", "proxy")}
    assert len(plants) >= 2
    for name, plant in plants.items():
        command = plant["command"]
        assert command[0] == "excite-sim", name
        assert flag_value(command, "server") == f"proxy:{PROXY_PORT}", name
        assert int(flag_value(command, "retry_unavailable_s")) >= 20, name
        config = flag_value(command, "config")
        assert (REPO / "sim" / "configs" / config[len(CONFIG_DIR):]).is_file(), config


def scale_documents():
    kustomization = yaml.safe_load((SCALE / "kustomization.yaml").read_text())
    docs = []
    for name in kustomization["resources"]:
        docs += [d for d in yaml.safe_load_all((SCALE / name).read_text()) if d]
    return kustomization, docs


@pytest.mark.parametrize("path", sorted(p.name for p in SCALE.glob("*.yaml")))
def test_every_scale_manifest_is_listed_in_its_kustomization(path):
    kustomization, _ = scale_documents()
    assert path == "kustomization.yaml" or path in kustomization["resources"]


def test_scale_secrets_are_made_by_make_secrets(tmp_path):
    kustomization, _ = scale_documents()
    generated = {g["name"]: dict(f.split("=", 1) for f in g["files"]) for g in kustomization["secretGenerator"]}
    assert set(generated) == {"excite-db", "excite-auth", "excite-tls"}
    out = tmp_path / "secrets"
    subprocess.run(["bash", str(K8S / "make-secrets.sh"), "ns1", str(out)], check=True, capture_output=True)
    for files in generated.values():
        for source in files.values():
            assert (out / source[len("secrets/"):]).stat().st_size > 0, source
    assert "/deploy/k8s/scale/secrets/" in (REPO / ".gitignore").read_text().split()
    images = {i["name"] for i in kustomization["images"]}
    _, docs = scale_documents()
    for doc in docs:
        pod = doc["spec"].get("template", {}).get("spec")
        if pod:
            for c in pod.get("containers", []) + pod.get("initContainers", []):
                assert c["image"] in images, (doc["metadata"]["name"], c["image"])


def test_scale_replicas_store_proxy_and_job_fit_together():
    kustomization, docs = scale_documents()
    deployment = one(docs, "Deployment", "excite-replicas")
    assert deployment["spec"]["replicas"] >= 2
    pod = deployment["spec"]["template"]["spec"]
    labels = deployment["spec"]["template"]["metadata"]["labels"]
    (server,) = pod["containers"]
    env = {e["name"]: e["value"] for e in server["env"]}
    assert {n[len("FLAGS_"):] for n in env} <= image_env_flags()
    assert "FLAGS_replica_id" not in env
    store = env["FLAGS_store"]
    assert store.startswith("postgresql://excite@") and "password" not in store
    postgres_service = one(docs, "Service", "excite-postgres")
    assert store.split("@")[1].split(":")[0] == postgres_service["metadata"]["name"]
    mounts = {m["mountPath"]: m["name"] for m in server["volumeMounts"]}
    volumes = {v["name"]: v for v in pod["volumes"]}
    assert secret_file(env["FLAGS_store_password_file"], mounts, volumes) == ("excite-db", "password")
    assert secret_file(env["FLAGS_auth_token_file"], mounts, volumes) == ("excite-auth", "token")
    assert server["securityContext"]["readOnlyRootFilesystem"] is True
    assert pod["securityContext"]["fsGroup"] == UID
    for probe in ("livenessProbe", "readinessProbe", "startupProbe"):
        assert server[probe]["exec"]["command"][0] == "excite-health", probe
    # The proxy finds the replicas through the headless Service's DNS name.
    headless = one(docs, "Service", "excite-replicas")
    assert headless["spec"]["clusterIP"] == "None"
    assert headless["spec"]["selector"].items() <= labels.items()
    template = [l for l in haproxy_lines(SCALE / "haproxy.cfg") if l.strip().startswith("server-template")]
    assert len(template) == 1 and f'"excite-replicas.${{POD_NAMESPACE}}.svc.cluster.local:{PORT}"' in template[0]
    proxy = one(docs, "Deployment", "excite-proxy")
    proxy_pod = proxy["spec"]["template"]["spec"]
    (haproxy,) = proxy_pod["containers"]
    assert {"name": "POD_NAMESPACE", "valueFrom": {"fieldRef": {"fieldPath": "metadata.namespace"}}} in haproxy["env"]
    proxy_mounts = {m["mountPath"]: m["name"] for m in haproxy["volumeMounts"]}
    proxy_volumes = {v["name"]: v for v in proxy_pod["volumes"]}
    config_path = haproxy["command"][-1]
    config_dir, config_name = config_path.rsplit("/", 1)
    config_volume = proxy_volumes[proxy_mounts[config_dir]]
    assert config_volume["configMap"]["name"] == "excite-haproxy"
    assert {"name": "excite-haproxy", "files": [config_name]} in kustomization["configMapGenerator"]
    bind = [l.strip() for l in haproxy_lines(SCALE / "haproxy.cfg") if l.strip().startswith("bind ")]
    assert bind == [f"bind :{PROXY_PORT} ssl crt /etc/haproxy/tls/excite.pem alpn h2"]
    tls = proxy_volumes[proxy_mounts["/etc/haproxy/tls"]]["secret"]
    assert tls["secretName"] == "excite-tls"
    assert {i["path"]: i["key"] for i in tls["items"]} == {"excite.pem": "tls.crt", "excite.pem.key": "tls.key"}
    assert {"name": "grpc", "containerPort": PROXY_PORT, "protocol": "TCP"} in haproxy["ports"]
    client_service = one(docs, "Service", "excite")
    assert client_service["spec"]["selector"].items() <= proxy["spec"]["template"]["metadata"]["labels"].items()
    assert client_service["spec"]["ports"][0]["port"] == PORT
    job = one(docs, "Job")
    (sim,) = job["spec"]["template"]["spec"]["containers"]
    assert flag_value(sim["command"], "server") == f"excite:{PORT}"
    assert int(flag_value(sim["command"], "retry_unavailable_s")) >= 20
    store_set = one(docs, "StatefulSet", "excite-postgres")
    (pg,) = store_set["spec"]["template"]["spec"]["containers"]
    pg_env = {e["name"]: e["value"] for e in pg["env"]}
    pg_mounts = {m["mountPath"]: m["name"] for m in pg["volumeMounts"]}
    pg_volumes = {v["name"]: v for v in store_set["spec"]["template"]["spec"]["volumes"]}
    assert secret_file(pg_env["POSTGRES_PASSWORD_FILE"], pg_mounts, pg_volumes) == ("excite-db", "password")
