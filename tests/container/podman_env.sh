# Sourced by the container tests: podman as it works on these machines, and the debian:12 base
# image made from Debian's packages when it is not there (no image registry is reachable).
#
# The kernel here refuses crun's cgroup set-up and podman's default rlimits: runc, cgroupfs and
# no default ulimits or pids limit, in a containers.conf of the test's own (CONTAINERS_CONF),
# so the machine's configuration is left alone; podman-compose's podman reads it too.
podman_conf_dir=$(mktemp -d)
cat > "$podman_conf_dir/containers.conf" <<'CONF'
[containers]
default_ulimits = []
pids_limit = 0

[engine]
cgroup_manager = "cgroupfs"
runtime = "runc"
CONF
export CONTAINERS_CONF="$podman_conf_dir/containers.conf"
podman_run() { podman --runtime runc run "$@"; }

# debian:12 as Docker Hub's image is: debootstrap's minbase variant of bookworm, with the same
# apt sources (bookworm, -updates, -security). Made once and kept in podman's image store.
ensure_debian_base() {
  if podman image exists debian:12; then return 0; fi
  local root
  root=$(mktemp -d)
  echo "making the debian:12 base image with debootstrap (once; kept by podman)"
  debootstrap --variant=minbase bookworm "$root" http://deb.debian.org/debian > "$root.log" 2>&1 \
    || { tail -n 20 "$root.log"; rm -rf "$root" "$root.log"; return 1; }
  rm -f "$root/etc/apt/sources.list"
  cat > "$root/etc/apt/sources.list.d/debian.sources" <<'SOURCES'
Types: deb
URIs: http://deb.debian.org/debian
Suites: bookworm bookworm-updates
Components: main
Signed-By: /usr/share/keyrings/debian-archive-keyring.gpg

Types: deb
URIs: http://deb.debian.org/debian-security
Suites: bookworm-security
Components: main
Signed-By: /usr/share/keyrings/debian-archive-keyring.gpg
SOURCES
  rm -rf "$root"/var/cache/apt/archives/*.deb "$root"/var/lib/apt/lists/* "$root"/var/log/* "$root"/tmp/*
  tar -C "$root" --numeric-owner -c . | podman import --change 'CMD ["bash"]' - debian:12 > /dev/null
  local status=$?
  rm -rf "$root" "$root.log"
  return $status
}
