#!/usr/bin/env bash
# Copied unchanged from ../shared/tools/container-engine.sh (a clean clone in CI has no ../shared).
# A real container engine on these machines (no Docker daemon, no Docker Hub):
# podman + podman-compose, with the settings this sandbox needs, and a base image
# debian:bookworm-slim built locally with debootstrap from Debian's packages.
# Idempotent; run as root. Afterwards:
#   podman build -t tyre-farm:latest .        (Dockerfile: FROM debian:bookworm-slim)
#   podman-compose up -d --scale worker=2      (reads docker-compose.yml)
#   podman-compose down
# `docker` and `docker compose` are not provided: call podman / podman-compose.
set -euo pipefail

need=()
for p in podman podman-compose runc debootstrap; do command -v "$p" >/dev/null || need+=("$p"); done
[ -e /usr/lib/cni/dnsname ] || need+=(golang-github-containernetworking-plugin-dnsname)
if [ ${#need[@]} -gt 0 ]; then
    apt-get update -qq
    DEBIAN_FRONTEND=noninteractive apt-get install -y -qq --no-install-recommends \
        "${need[@]}" uidmap slirp4netns >/dev/null
fi

# crun cannot run here (hybrid cgroups; no RLIMIT_NOFILE raise): runc, cgroupfs, no ulimits.
mkdir -p /etc/containers
cat > /etc/containers/containers.conf <<'CONF'
[containers]
default_ulimits = []
[engine]
runtime = "runc"
cgroup_manager = "cgroupfs"
events_logger = "file"
CONF

# Base image: Debian bookworm, minimal, trusting this machine's CA bundle (the package
# registries are reached through it) for apt, pip and update-ca-certificates alike.
base=docker.io/library/debian:bookworm-slim
if ! podman image exists "$base"; then
    root=$(mktemp -d)
    trap 'rm -rf "$root"' EXIT
    debootstrap --variant=minbase bookworm "$root" http://deb.debian.org/debian >/dev/null
    mkdir -p "$root/usr/local/share/ca-certificates"
    cp /etc/ssl/certs/ca-certificates.crt "$root/usr/local/share/ca-certificates/host-bundle.crt"
    mkdir -p "$root/etc/ssl/certs"
    cp /etc/ssl/certs/ca-certificates.crt "$root/etc/ssl/certs/ca-certificates.crt"
    printf '[global]\ncert = /usr/local/share/ca-certificates/host-bundle.crt\n' > "$root/etc/pip.conf"
    rm -rf "$root"/var/cache/apt/archives/*.deb "$root"/var/lib/apt/lists/*
    tar -C "$root" -c . | podman import --change 'CMD ["bash"]' - "$base" >/dev/null
fi
echo "container engine ready: $(podman --version), $(podman-compose version 2>/dev/null | grep -i 'podman-compose' | head -1); base image $base"
