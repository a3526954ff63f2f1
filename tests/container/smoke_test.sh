#!/usr/bin/env bash
# Container smoke test (ctest label "container"): builds the excite image from
# deploy/Containerfile with podman and runs it the way a deployment does.
#
#  1. base image: localhost/debian:bookworm from Debian's mirror (debootstrap), only
#     if it is not there yet (deploy/podman/base-image.sh);
#  2. the image (podman's layer cache makes an unchanged rebuild quick); checks that
#     it runs as a non-root user, has no compiler or headers, exposes 50051, has a
#     health check and a data volume;
#  3. the server container, read-only root filesystem, data on a named volume, no
#     --init (excite-server is PID 1); waits until its HEALTHCHECK (excite-health,
#     grpc.health.v1) says healthy;
#  4. a plant container on the same network: excite-sim explores the pendulum with
#     rec for $EXCITE_SMOKE_SAMPLES samples; checks the JSON summary;
#  5. the excite CLI from a third container sees the kept session;
#  6. SIGTERM to the server: must exit 0 within the drain time and log it;
#  7. a new server container on the same volume still has the session (durable
#     store on the volume); podman stop (SIGTERM) again exits 0;
#  8. deploy/compose.yaml with podman-compose: the server and both plant clients
#     (10 samples each); both plants exit 0 and leave their summaries on the named
#     volume; the server answers on the published host port; down -v.
#  9. deploy/compose.scale.yaml: PostgreSQL and HAProxy images from Debian's
#     packages, three replicas, two plants through the proxy; the replica that
#     serves a plant's session is killed (SIGKILL) mid-exploration; both plants
#     still finish (40 samples each, summaries on the volume); ListSessions
#     answers through the proxy; down -v.
#
# Environment: EXCITE_BASE_IMAGE (default localhost/debian:bookworm),
# EXCITE_IMAGE (default localhost/excite:ci), EXCITE_SMOKE_SAMPLES (default 30),
# CONTAINERS_CONF (default deploy/podman/containers.conf). Needs root and podman,
# runc, debootstrap (scripts/setup.sh installs them).
set -euo pipefail
repo="$(cd "$(dirname "$0")/../.." && pwd)"
cd "$repo"
export CONTAINERS_CONF="${CONTAINERS_CONF:-$repo/deploy/podman/containers.conf}"
base="${EXCITE_BASE_IMAGE:-localhost/debian:bookworm}"
image="${EXCITE_IMAGE:-localhost/excite:ci}"
samples="${EXCITE_SMOKE_SAMPLES:-30}"
tag="excite-smoke-$$"
net="$tag-net"
vol="$tag-data"
server="$tag-server"
out="$(mktemp -d /tmp/excite-smoke.XXXXXX)"
t0=$SECONDS

log() { echo "[smoke $((SECONDS - t0))s] $*"; }
fail() {
  echo "[smoke] FAIL: $*" >&2
  [ -s "$out/podman.log" ] && { echo "--- podman messages" >&2; cat "$out/podman.log" >&2; }
  for c in "$server" "$server-2"; do
    if podman container exists "$c" 2>/dev/null; then
      echo "--- logs of $c" >&2
      podman logs "$c" >&2 2>&1 || true
    fi
  done
  if [ -n "${scale_up:-}" ]; then
    for c in proxy excite-1 excite-2 excite-3 postgres; do
      echo "--- last lines of compose.scale's $c" >&2
      podman logs --tail 60 "${tag}-scale_${c}_1" >&2 2>&1 || true
    done
  fi
  exit 1
}
compose() {
  EXCITE_IMAGE="$image" EXCITE_SAMPLES=10 EXCITE_PORT="${host_port:-0}" \
    podman-compose -p "$tag" -f deploy/compose.yaml "$@"
}
scale() {
  EXCITE_IMAGE="$image" EXCITE_POSTGRES_IMAGE="$image-postgres" \
    EXCITE_HAPROXY_IMAGE="$image-haproxy" EXCITE_SAMPLES=40 \
    EXCITE_PORT="${scale_port:-0}" EXCITE_DB_PASSWORD="smoke-$$-$RANDOM" \
    podman-compose -p "$tag-scale" -f deploy/compose.scale.yaml "$@"
}
cleanup() {
  if [ -n "${compose_up:-}" ]; then
    podman rm -f -v "${tag}_pendulum-rec_1" "${tag}_pendulum-pa_1" >/dev/null 2>&1 || true
    compose down -v >/dev/null 2>&1 || true
  fi
  if [ -n "${scale_up:-}" ]; then
    scale logs >"$out/scale-logs.txt" 2>&1 || true
    podman rm -f -v "${tag}-scale_pendulum-rec_1" "${tag}-scale_unicycle-rec_1" \
      >/dev/null 2>&1 || true
    scale down -v >/dev/null 2>&1 || true
  fi
  podman rm -f -t 0 "$server" "$server-2" >/dev/null 2>&1 || true
  podman volume rm -f "$vol" >/dev/null 2>&1 || true
  podman network rm -f "$net" >/dev/null 2>&1 || true
  rm -rf "$out"
}
trap cleanup EXIT

for tool in podman runc debootstrap podman-compose /usr/bin/python3; do
  command -v "$tool" >/dev/null || fail "$tool is missing (run scripts/setup.sh)"
done

# 1. Base image.
deploy/podman/base-image.sh "$base"
log "base image ready"

# 2. Image. --format docker keeps the HEALTHCHECK (OCI images have none).
podman build --format docker --jobs 2 --build-arg BASE="$base" \
  -f deploy/Containerfile -t "$image" . >"$out/build.log" 2>&1 ||
  { tail -40 "$out/build.log" >&2; fail "podman build failed"; }
size=$(podman image inspect --format '{{.Size}}' "$image")
log "image $image built: $((size / 1000000)) MB"
# (Outputs go to variables before grep: with pipefail, grep -q closing the pipe early
# would fail the producer.)
config=$(podman image inspect --format '{{.Config.User}} {{json .Config.ExposedPorts}}
{{json .Config.Volumes}} {{json .Config.Healthcheck}}' "$image")
[[ "$config" == "10001:10001 "* ]] || fail "image does not run as user 10001:10001: $config"
[[ "$config" == *'"50051/tcp"'* ]] || fail "image does not expose 50051/tcp: $config"
[[ "$config" == *'"/var/lib/excite"'* ]] || fail "image has no /var/lib/excite volume: $config"
[[ "$config" == *excite-health* ]] || fail "image has no excite-health HEALTHCHECK: $config"
# Runtime stage: binaries and libraries only.
podman run --rm --no-healthcheck --entrypoint /bin/sh "$image" -c \
  'for t in c++ g++ cmake protoc; do command -v $t && exit 1; done
   test ! -e /usr/include/grpcpp && test ! -e /src && id -u' >"$out/probe.txt" ||
  fail "runtime image holds build tools or sources: $(cat "$out/probe.txt")"
[ "$(cat "$out/probe.txt")" = "10001" ] || fail "container user is $(cat "$out/probe.txt")"

# 3. Server: PID 1, read-only root, data on a named volume.
podman network create "$net" >/dev/null
podman volume create "$vol" >/dev/null
# --health-interval=disable: no systemd timer for the check here (there is no systemd
# to run it); the check itself stays and `podman healthcheck run` runs it.
podman run -d --name "$server" --network "$net" --read-only --health-interval=disable \
  -v "$vol:/var/lib/excite" -e FLAGS_log_level=info "$image" >/dev/null 2>>"$out/podman.log"
healthy=0
for _ in $(seq 1 60); do
  if podman healthcheck run "$server" >/dev/null 2>&1; then
    healthy=1
    break
  fi
  sleep 1
done
[ "$healthy" = 1 ] || fail "server never became healthy (grpc.health.v1 SERVING)"
pid1=$(podman exec "$server" cat /proc/1/cmdline | tr '\0' ' ')
[[ "$pid1" == "excite-server "* ]] || fail "PID 1 is not excite-server: $pid1"
log "server healthy"

# 4. Plant client in a second container.
chmod 0777 "$out"
podman run --rm --no-healthcheck --network "$net" --read-only -v "$out:/out" "$image" \
  excite-sim --server="$server:50051" \
  --config=/usr/local/share/excite/configs/pendulum.textproto --strategy=rec \
  --samples="$samples" --seed=1 --session_id=smoke --keep_session \
  --summary=/out/summary.json >"$out/sim.log" 2>&1 ||
  { cat "$out/sim.log" >&2; fail "excite-sim failed"; }
log "exploration done: $(grep '^final' "$out/sim.log" || true)"
/usr/bin/python3 - "$out/summary.json" "$samples" <<'PY' || fail "summary check failed"
import json, math, sys
s = json.load(open(sys.argv[1]))
n = int(sys.argv[2])
def check(ok, what):
    if not ok:
        sys.exit(f"summary: {what}: {json.dumps(s)}")
check(s["system"] == "pendulum", "system")
check(s["strategy"] == "rec", "strategy")
check(s["session"] == "sessions/smoke", "session name")
check(s["samples"] == n, "samples")
rmse = s["final_rmse"]
check(isinstance(rmse, float) and math.isfinite(rmse) and 0 < rmse < 5, "final_rmse")
hist = s["rmse_history"]
check(len(hist) >= 2 and hist[-1][0] == n and hist[-1][1] == rmse, "rmse_history")
check(all(a[0] < b[0] for a, b in zip(hist, hist[1:])), "rmse_history order")
check(0 < s["coverage_marginal"] <= 1, "coverage_marginal")
check(s["random_steps"] >= 1 and s["plans"] >= 1, "plans and random steps")
# rec applies one planned input per plan: every sample is a plan or a random step.
check(s["plans"] + s["random_steps"] == n, "plans + random_steps == samples")
check(s["plan_ms_p50"] > 0, "plan_ms_p50")
print(f"summary ok: final_rmse {rmse:.3f}, coverage {s['coverage_marginal']:.2f}, "
      f"plans {s['plans']}, plan_ms_p50 {s['plan_ms_p50']:.0f}, wall_s {s['wall_s']:.1f}")
PY

# 5. The CLI sees the kept session.
podman run --rm --no-healthcheck --network "$net" "$image" \
  excite --server="$server:50051" sessions get smoke >"$out/get.txt" 2>&1 ||
  { cat "$out/get.txt" >&2; fail "excite sessions get failed"; }
grep -q "^sample_count: $samples\$" "$out/get.txt" ||
  fail "session has not $samples samples: $(cat "$out/get.txt")"

# 6. SIGTERM to PID 1: graceful drain and exit 0.
stop_start=$SECONDS
podman kill --signal TERM "$server" >/dev/null
code=$(timeout 30 podman wait "$server") || fail "server did not stop within 30 s of SIGTERM"
[ "$code" = 0 ] || fail "server exited with $code after SIGTERM (want 0)"
podman logs "$server" >"$out/server.log" 2>&1
grep -q 'received SIGTERM' "$out/server.log" || fail "server did not log SIGTERM"
log "server stopped by SIGTERM in $((SECONDS - stop_start)) s, exit 0"

# 7. The session survives on the volume; podman stop exits 0 as well.
podman run -d --name "$server-2" --network "$net" --read-only --health-interval=disable \
  -v "$vol:/var/lib/excite" "$image" >/dev/null 2>>"$out/podman.log"
podman run --rm --no-healthcheck --network "$net" "$image" excite-health --server="$server-2:50051" \
  --wait_s=60 >/dev/null || fail "restarted server never became healthy"
podman run --rm --no-healthcheck --network "$net" "$image" \
  excite --server="$server-2:50051" sessions get smoke >"$out/get2.txt" 2>&1 ||
  { cat "$out/get2.txt" >&2; fail "session lost after restart"; }
grep -q "^sample_count: $samples\$" "$out/get2.txt" ||
  fail "restarted session has not $samples samples: $(cat "$out/get2.txt")"
podman stop -t 20 "$server-2" >/dev/null 2>>"$out/podman.log"
code=$(podman inspect --format '{{.State.ExitCode}}' "$server-2")
[ "$code" = 0 ] || fail "podman stop: server exited with $code (want 0)"
log "restart kept the session; podman stop exit 0"

# 8. The compose stack.
host_port=$(/usr/bin/python3 -c 'import socket; s = socket.socket(); s.bind(("127.0.0.1", 0)); print(s.getsockname()[1])')
compose_up=1
compose up -d >"$out/compose.log" 2>&1 || { cat "$out/compose.log" >&2; fail "compose up failed"; }
for plant in pendulum-rec pendulum-pa; do
  code=$(timeout 300 podman wait "${tag}_${plant}_1") || fail "compose: $plant did not finish"
  if [ "$code" != 0 ]; then
    podman logs "${tag}_${plant}_1" >&2 || true
    fail "compose: $plant exited with $code"
  fi
done
mkdir -p "$out/compose" && chmod 0777 "$out/compose"
podman run --rm --no-healthcheck -v "${tag}_excite-results:/results" -v "$out/compose:/out" \
  "$image" sh -c 'cp /results/pendulum-rec.json /results/pendulum-pa.json /out/' ||
  fail "compose: summaries missing on the excite-results volume"
/usr/bin/python3 - "$out/compose" <<'PY' || fail "compose: summary check failed"
import json, math, sys
for strategy in ("rec", "pa"):
    s = json.load(open(f"{sys.argv[1]}/pendulum-{strategy}.json"))
    if s["strategy"] != strategy or s["samples"] != 10 or not math.isfinite(s["final_rmse"]):
        sys.exit(f"compose summary {strategy}: {json.dumps(s)}")
PY
podman run --rm --no-healthcheck --network host "$image" \
  excite-health --server="127.0.0.1:$host_port" >/dev/null ||
  fail "compose: server not reachable on the published port $host_port"
# The plants got anonymous volumes for the image's VOLUME; podman-compose 1.0.3's
# down -v leaves those behind, so remove them with their containers first.
podman rm -f -v "${tag}_pendulum-rec_1" "${tag}_pendulum-pa_1" >/dev/null 2>&1 || true
compose down -v >>"$out/compose.log" 2>&1 || { cat "$out/compose.log" >&2; fail "compose down failed"; }
compose_up=
log "compose stack: server and two plants ran, summaries on the volume; PASS"

# 9. The scaled-out stack, with one replica killed while the plants explore.
for part in postgres haproxy; do
  podman build --format docker --build-arg BASE="$base" -f "deploy/$part/Containerfile" \
    -t "$image-$part" "deploy/$part" >"$out/build-$part.log" 2>&1 ||
    { tail -20 "$out/build-$part.log" >&2; fail "podman build of deploy/$part failed"; }
done
scale_port=$(/usr/bin/python3 -c 'import socket; s = socket.socket(); s.bind(("127.0.0.1", 0)); print(s.getsockname()[1])')
scale_up=1
scale up -d >"$out/scale.log" 2>&1 || { cat "$out/scale.log" >&2; fail "compose.scale up failed"; }
# Resends after UNAVAILABLE: right after a replica is killed the proxy may still
# route a call to it (503) until its health check marks it down.
cli() {
  podman run --rm --no-healthcheck --network host "$image" \
    excite --server="127.0.0.1:$scale_port" --retry_unavailable_s=30 "$@"
}
# Wait until both sessions hold samples, then kill the replica serving one.
victim=""
for _ in $(seq 1 120); do
  owner=$(podman exec "${tag}-scale_postgres_1" psql -U excite -d excite -tA -c \
    "SELECT owner FROM sessions WHERE owner IS NOT NULL ORDER BY id LIMIT 1" 2>/dev/null ||
    true)
  held=$(podman exec "${tag}-scale_postgres_1" psql -U excite -d excite -tA -c \
    "SELECT count(*) FROM samples" 2>/dev/null || echo 0)
  if [ -n "$owner" ] && [ "${held:-0}" -ge 20 ]; then
    victim=$(echo "$owner" | cut -d- -f1-2)  # owner: excite-N-PID-SUFFIX
    break
  fi
  sleep 1
done
[ -n "$victim" ] || fail "compose.scale: no session got samples"
podman kill --signal KILL "${tag}-scale_${victim}_1" >/dev/null
log "compose.scale: killed $victim (it served a session) at $held stored samples"
for plant in pendulum-rec unicycle-rec; do
  code=$(timeout 400 podman wait "${tag}-scale_${plant}_1") ||
    fail "compose.scale: $plant did not finish"
  if [ "$code" != 0 ]; then
    podman logs "${tag}-scale_${plant}_1" >&2 || true
    fail "compose.scale: $plant exited with $code"
  fi
done
mkdir -p "$out/scale" && chmod 0777 "$out/scale"
podman run --rm --no-healthcheck -v "${tag}-scale_excite-results:/results" -v "$out/scale:/out" \
  "$image" sh -c 'cp /results/pendulum-rec.json /results/unicycle-rec.json /out/' ||
  fail "compose.scale: summaries missing on the excite-results volume"
/usr/bin/python3 - "$out/scale" <<'PY' || fail "compose.scale: summary check failed"
import json, math, sys
for system in ("pendulum", "unicycle"):
    s = json.load(open(f"{sys.argv[1]}/{system}-rec.json"))
    if s["system"] != system or s["samples"] != 40 or not math.isfinite(s["final_rmse"]):
        sys.exit(f"compose.scale summary {system}: {json.dumps(s)}")
PY
cli sessions list >"$out/scale-list.txt" 2>&1 ||
  { cat "$out/scale-list.txt" >&2; fail "compose.scale: sessions list through the proxy"; }
podman rm -f -v "${tag}-scale_pendulum-rec_1" "${tag}-scale_unicycle-rec_1" >/dev/null 2>&1 || true
scale down -v >>"$out/scale.log" 2>&1 || { cat "$out/scale.log" >&2; fail "compose.scale down failed"; }
scale_up=
log "compose.scale: three replicas, one killed mid-run, both plants finished; PASS"
