#!/usr/bin/env bash
# The main job: installs what is missing, builds, starts excite-server on loopback
# (data in ./.excite-data), and runs excite-sim as a separate process: a pendulum
# explored with the rec strategy. Extra arguments go to excite-sim
# and override these (e.g. --strategy=pa --samples=150); the last value of a flag wins.
set -euo pipefail
cd "$(dirname "$0")/.."
scripts/setup.sh

bin=build/release
mkdir -p results .excite-data
log=$(mktemp)
"$bin/server/excite-server" --listen=127.0.0.1:0 --data_dir=.excite-data >"$log" 2>&1 &
server=$!
trap 'kill -TERM $server 2>/dev/null; wait $server 2>/dev/null; rm -f "$log"' EXIT

address=""
for _ in $(seq 1 100); do
  address=$(sed -n 's/^excite-server listening on //p' "$log")
  [ -n "$address" ] && break
  kill -0 $server 2>/dev/null || { cat "$log"; echo "excite-server failed to start"; exit 1; }
  sleep 0.1
done
[ -n "$address" ] || { cat "$log"; echo "excite-server did not start in 10 s"; exit 1; }
echo "excite-server listening on $address (pid $server)"

"$bin/sim/excite-sim" --server="$address" --config=sim/configs/pendulum.textproto \
  --strategy=rec --summary=results/demo.json "$@"
