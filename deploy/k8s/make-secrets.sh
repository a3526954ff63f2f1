#!/usr/bin/env bash
# Makes the files kustomization.yaml's secretGenerator reads, in deploy/k8s/secrets/
# (git-ignored; keep them, or your own, out of version control):
#   token             a random bearer token (clients send it; EXCITE_AUTH_TOKEN)
#   db-password       a random password of the PostgreSQL user (deploy/k8s/scale)
#   ca.crt            a private CA that clients trust (--tls_ca)
#   tls.crt, tls.key  the server's certificate, signed by that CA, for the Services'
#                     names in NAMESPACE and for 127.0.0.1 (the probes)
#
#   deploy/k8s/make-secrets.sh [NAMESPACE [DIR]]     (default: default, deploy/k8s/secrets)
#
# It never overwrites: delete the directory to make new ones (then re-apply, and
# restart the server and clients; kustomize names each Secret by a hash of its
# content, so pods pick up the new one when they are rolled).
set -euo pipefail
namespace=${1:-default}
dir=${2:-"$(dirname "$0")/secrets"}
if [[ -e "$dir/token" || -e "$dir/tls.crt" ]]; then
  echo "make-secrets: $dir already holds secrets; delete it to make new ones" >&2
  exit 1
fi
mkdir -p "$dir"
chmod 0700 "$dir"
cd "$dir"
umask 077
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT

openssl rand -hex 32 > token
openssl rand -hex 24 > db-password
openssl req -x509 -newkey ec -pkeyopt ec_paramgen_curve:P-256 -nodes -days 825 \
  -subj "/CN=excite CA" -keyout "$work/ca.key" -out ca.crt 2>"$work/log"
svc="excite.${namespace}.svc"
san="DNS:excite,DNS:${svc},DNS:${svc}.cluster.local"
san+=",DNS:*.excite-headless.${namespace}.svc.cluster.local,DNS:localhost,IP:127.0.0.1"
openssl req -newkey ec -pkeyopt ec_paramgen_curve:P-256 -nodes -subj "/CN=excite" \
  -keyout tls.key -out "$work/server.csr" 2>>"$work/log"
openssl x509 -req -in "$work/server.csr" -CA ca.crt -CAkey "$work/ca.key" \
  -CAcreateserial -CAserial "$work/ca.srl" -days 825 -extfile <(
    printf 'subjectAltName=%s\nextendedKeyUsage=serverAuth\n' "$san") \
  -out tls.crt 2>>"$work/log"
chmod 0644 ca.crt tls.crt
echo "make-secrets: wrote token, db-password, ca.crt, tls.crt, tls.key to $dir (namespace $namespace);"
echo "  the CA's key is not kept: make new files to issue another certificate."
