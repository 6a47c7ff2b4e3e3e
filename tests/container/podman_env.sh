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

# The Debian 12 apt sources this machine itself is configured with, as deb822 stanzas: the `deb`
# entries of ETC/sources.list and ETC/sources.list.d/*.list (one-line `deb [options] URI SUITE
# COMPONENTS...`) and of ETC/sources.list.d/*.sources (deb822), in apt's order, whose suites are
# bookworm or bookworm-* (updates, security, backports); other repositories, deb-src, `Enabled:
# no` stanzas and files not named *.list or *.sources (disabled ones) are left out. ETC is
# /etc/apt unless given. Prints nothing and returns 1 when there is no such entry.
host_debian_sources() {
  local etc=${1:-/etc/apt} f files=()
  [ -f "$etc/sources.list" ] && files+=("$etc/sources.list")
  for f in "$etc"/sources.list.d/*; do
    case $f in *.list | *.sources) [ -f "$f" ] && files+=("$f") ;; esac
  done
  [ ${#files[@]} -gt 0 ] || return 1
  awk '
    function kept_suites(list,   n, w, i, out) {  # the bookworm* words of a suite list
      n = split(list, w, /[ \t\n]+/); out = ""
      for (i = 1; i <= n; i++) if (w[i] ~ /^bookworm/) out = out (out == "" ? "" : " ") w[i]
      return out
    }
    function has_word(list, word,   n, w, i) {
      n = split(list, w, /[ \t\n]+/)
      for (i = 1; i <= n; i++) if (w[i] == word) return 1
      return 0
    }
    function flush(   suites, i, name) {  # the deb822 stanza read so far
      if (nf > 0 && tolower(val["enabled"]) !~ /^[ \t]*no[ \t]*$/ && has_word(val["types"], "deb") \
          && (suites = kept_suites(val["suites"])) != "") {
        printf "%sTypes: deb\nURIs: %s\nSuites: %s\n", (found++ ? "\n" : ""), trim(val["uris"]), suites
        for (i = 1; i <= nf; i++) {
          name = tolower(field[i])
          if (name != "types" && name != "uris" && name != "suites" && name != "enabled")
            printf "%s:%s%s\n", field[i], (val[name] == "" || substr(val[name], 1, 1) == "\n" ? "" : " "), val[name]
        }
      }
      for (i = 1; i <= nf; i++) delete val[tolower(field[i])]
      nf = 0; last = ""
    }
    function trim(s) { sub(/^[ \t]+/, "", s); sub(/[ \t]+$/, "", s); return s }
    function option_name(k,   n, p, i, out) {  # one-line option -> deb822 field (apt reads them case-blind)
      if (k == "arch") return "Architectures"
      if (k == "lang") return "Languages"
      if (k == "target") return "Targets"
      if (k == "pdiffs") return "PDiffs"
      n = split(k, p, "-"); out = ""
      for (i = 1; i <= n; i++) out = out (i > 1 ? "-" : "") toupper(substr(p[i], 1, 1)) substr(p[i], 2)
      return out
    }
    function one_line(line,   w, n, i, opts, o, no, kv, k, v, comps) {
      sub(/#.*/, "", line); line = trim(line)
      n = split(line, w, /[ \t]+/)
      if (n == 0 || w[1] != "deb") return
      i = 2; opts = ""
      if (substr(w[2], 1, 1) == "[") {  # [ key=value ... ], possibly spaced
        for (; i <= n; i++) { opts = opts " " w[i]; if (w[i] ~ /\]$/) { i++; break } }
        gsub(/\[/, " ", opts); gsub(/\]/, " ", opts)
      }
      if (i + 1 > n || w[i + 1] !~ /^bookworm/) return
      comps = ""
      for (k = i + 2; k <= n; k++) comps = comps (comps == "" ? "" : " ") w[k]
      printf "%sTypes: deb\nURIs: %s\nSuites: %s\n", (found++ ? "\n" : ""), w[i], w[i + 1]
      if (comps != "") printf "Components: %s\n", comps
      no = split(opts, o, /[ \t]+/)
      for (k = 1; k <= no; k++) {
        if (o[k] == "" || index(o[k], "=") == 0) continue
        v = substr(o[k], index(o[k], "=") + 1); kv = substr(o[k], 1, index(o[k], "=") - 1)
        if (kv ~ /^(arch|lang|target|signed-by)$/) gsub(/,/, " ", v)
        printf "%s: %s\n", option_name(kv), v
      }
    }
    FNR == 1 { flush() }
    FILENAME !~ /\.sources$/ { one_line($0); next }
    /^[ \t]*#/ { next }
    /^[ \t]*$/ { flush(); next }
    /^[ \t]/ { if (last != "") val[last] = val[last] "\n" $0; next }  # a continuation line
    {
      name = substr($0, 1, index($0, ":") - 1)
      if (name == "") next
      last = tolower(name); field[++nf] = name
      val[last] = trim(substr($0, index($0, ":") + 1))
    }
    END { flush(); exit(found ? 0 : 1) }
  ' "${files[@]}"
}

# What debootstrap needs from those stanzas (on stdin): the main archive, i.e. the first URI of
# the first stanza whose suites include bookworm itself (not -security or -updates), and the
# keyring it is signed with when the stanza names one as a .gpg file. Prints "URI [KEYRING]";
# returns 1 when there is no such stanza.
debootstrap_source() {
  awk '
    function flush() {
      if (!done && (" " suites " ") ~ / bookworm / && uri != "") {
        print uri (keyring ~ /^\/.*\.gpg$/ ? " " keyring : ""); done = 1
      }
      suites = ""; uri = ""; keyring = ""
    }
    /^[ \t]*$/ { flush(); next }
    tolower($1) == "suites:" { $1 = ""; suites = $0; gsub(/[ \t]+/, " ", suites) }
    tolower($1) == "uris:" { uri = $2 }
    tolower($1) == "signed-by:" && NF == 2 { keyring = $2 }
    END { flush(); exit(done ? 0 : 1) }
  '
}

# debian:12 as Docker Hub's image is: debootstrap's minbase variant of bookworm. Its mirror and
# the image's apt sources are this machine's own (host_debian_sources: no host name is written
# here). Made once and kept in podman's image store.
ensure_debian_base() {
  if podman image exists debian:12; then return 0; fi
  local sources mirror keyring root key
  if ! sources=$(host_debian_sources); then
    echo "cannot make the debian:12 base image: this machine's apt configuration (/etc/apt/sources.list," \
         "/etc/apt/sources.list.d/*.list, *.sources) has no enabled Debian 12 (bookworm) 'deb' entry to take it from" >&2
    return 1
  fi
  if ! read -r mirror keyring < <(debootstrap_source <<< "$sources"); then
    echo "cannot make the debian:12 base image: this machine's apt sources name no archive for the suite" \
         "bookworm itself (only bookworm-*), which debootstrap needs" >&2
    return 1
  fi
  root=$(mktemp -d)
  echo "making the debian:12 base image with debootstrap from $mirror (once; kept by podman)"
  debootstrap --variant=minbase ${keyring:+--keyring="$keyring"} bookworm "$root" "$mirror" > "$root.log" 2>&1 \
    || { tail -n 20 "$root.log"; rm -rf "$root" "$root.log"; return 1; }
  rm -f "$root/etc/apt/sources.list" "$root"/etc/apt/sources.list.d/*
  printf '%s\n' "$sources" > "$root/etc/apt/sources.list.d/debian.sources"
  # A keyring the entries name that the new system lacks: this machine's copy.
  while read -r key; do
    if [ ! -e "$root$key" ] && [ -f "$key" ]; then mkdir -p "$root$(dirname "$key")" && cp "$key" "$root$key"; fi
  done < <(awk 'tolower($1) == "signed-by:" && NF == 2 && $2 ~ /^\// {print $2}' <<< "$sources")
  rm -rf "$root"/var/cache/apt/archives/*.deb "$root"/var/lib/apt/lists/* "$root"/var/log/* "$root"/tmp/*
  tar -C "$root" --numeric-owner -c . | podman import --change 'CMD ["bash"]' - debian:12 > /dev/null
  local status=$?
  rm -rf "$root" "$root.log"
  return $status
}
