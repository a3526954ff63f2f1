#!/usr/bin/env bash
# Builds a local Debian 12 base image for deploy/Containerfile on machines without
# registry access, from Debian's package mirror with debootstrap:
#
#   deploy/podman/base-image.sh [IMAGE]        (default localhost/debian:bookworm)
#   podman build --build-arg BASE=localhost/debian:bookworm -f deploy/Containerfile .
#
# Idempotent: does nothing if IMAGE exists. Needs root, podman and debootstrap. The
# rootfs is trimmed like debian:bookworm-slim (no docs, man pages, locales, apt
# lists or caches, and a dpkg config that keeps later installs free of them).
# Mirror: $EXCITE_DEBIAN_MIRROR, else the one apt on this machine uses, else
# http://deb.debian.org/debian.
set -euo pipefail
here="$(cd "$(dirname "$0")" && pwd)"
image="${1:-localhost/debian:bookworm}"
export CONTAINERS_CONF="${CONTAINERS_CONF:-$here/containers.conf}"

# One builder at a time; a second caller waits and then finds the image.
exec 9>"/tmp/excite-base-image.lock"
flock 9
if podman image exists "$image"; then
  echo "base image $image: present"
  exit 0
fi

mirror_of_apt() {
  local uri=""
  if [ -r /etc/apt/sources.list.d/debian.sources ]; then
    uri=$(awk '/^URIs:/ {print $2; exit}' /etc/apt/sources.list.d/debian.sources)
  fi
  if [ -z "$uri" ] && [ -r /etc/apt/sources.list ]; then
    uri=$(awk '$1 == "deb" && $3 ~ /^bookworm$/ {print $2; exit}' /etc/apt/sources.list)
  fi
  echo "${uri:-http://deb.debian.org/debian}"
}
mirror="${EXCITE_DEBIAN_MIRROR:-$(mirror_of_apt)}"

rootfs=$(mktemp -d /var/tmp/excite-rootfs.XXXXXX)
trap 'rm -rf "$rootfs"' EXIT
echo "base image $image: debootstrap bookworm from $mirror"
debootstrap --variant=minbase bookworm "$rootfs" "$mirror" >"$rootfs.log" 2>&1 || {
  tail -20 "$rootfs.log" >&2
  rm -f "$rootfs.log"
  exit 1
}
rm -f "$rootfs.log"

# As in the slim images: later package installs leave out documentation and locales.
cat >"$rootfs/etc/dpkg/dpkg.cfg.d/excite-slim" <<'CFG'
path-exclude /usr/share/doc/*
path-include /usr/share/doc/*/copyright
path-exclude /usr/share/man/*
path-exclude /usr/share/info/*
path-exclude /usr/share/locale/*
path-include /usr/share/locale/locale.alias
CFG
cat >"$rootfs/etc/apt/apt.conf.d/excite-slim" <<'CFG'
APT::Install-Recommends "false";
Dir::Cache::pkgcache "";
Dir::Cache::srcpkgcache "";
CFG
printf 'deb %s bookworm main\ndeb %s bookworm-updates main\n' "$mirror" "$mirror" \
  >"$rootfs/etc/apt/sources.list"

tar -C "$rootfs" \
  --exclude='./var/cache/apt/*' --exclude='./var/lib/apt/lists/*' \
  --exclude='./usr/share/doc/*' --exclude='./usr/share/man/*' \
  --exclude='./usr/share/info/*' --exclude='./usr/share/locale/*' \
  -c . |
  podman import --quiet \
    --change 'ENV PATH=/usr/local/sbin:/usr/local/bin:/usr/sbin:/usr/bin:/sbin:/bin' \
    --change 'CMD ["/bin/bash"]' - "$image" >/dev/null
echo "base image $image: imported ($(podman image inspect --format '{{.Size}}' "$image") bytes)"
