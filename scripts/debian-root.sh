# Helpers shared by scripts/test-release.sh and scripts/test-container.sh (sourced, not run): a fresh
# minimal Debian root of a release, from this machine's Debian mirrors and with its settings, so the
# root reaches exactly the registries this machine reaches.

# A download that failed: the mirror (or the network to it) is out of reach, not a project failure.
network_failure() {
  grep -Eq 'Failed to fetch|Temporary failure resolving|Could not resolve|Could not connect|Unable to connect|Connection timed out|Connection refused|Network is unreachable|No route to host|Unable to fetch some archives|Some index files failed to download|Hash Sum mismatch' "$1"
}

# This machine's Debian mirrors (deb822 .sources and one-line .list files), with its own suites
# (host, host-updates, host-security) swapped for RELEASE's, one "deb URI SUITE COMPONENTS" a line;
# deb.debian.org when it names none.
host_mirrors() {
  local release="$1" host_release mirrors f
  host_release="$(. /etc/os-release && echo "${VERSION_CODENAME:-}")"
  mirrors="$(
    {
      for f in /etc/apt/sources.list.d/*.sources; do [ -f "$f" ] && { cat "$f"; echo; }; done |
        awk 'BEGIN {RS=""; FS="\n"} {
          types=""; uris=""; suites=""; comps=""; enabled="yes"
          for (i = 1; i <= NF; i++) {
            if ($i ~ /^#/) continue
            split($i, kv, ":"); key=tolower(kv[1]); val=substr($i, length(kv[1]) + 2); gsub(/^[ \t]+/, "", val)
            if (key == "types") types=val; else if (key == "uris") uris=val
            else if (key == "suites") suites=val; else if (key == "components") comps=val
            else if (key == "enabled") enabled=val
          }
          if (enabled == "no" || types !~ /(^| )deb( |$)/) next
          nu=split(uris, u, " "); ns=split(suites, s, " ")
          for (a = 1; a <= nu; a++) for (b = 1; b <= ns; b++) print u[a], s[b], comps
        }'
      { cat /etc/apt/sources.list /etc/apt/sources.list.d/*.list 2>/dev/null || true; } |
        awk '$1 == "deb" { i=2; if ($2 ~ /^\[/) { while ($i !~ /\]$/) i++; i++ }
                            c=""; for (j = i + 2; j <= NF; j++) c = c " " $j; print $i, $(i+1), substr(c, 2) }'
    } | awk -v h="$host_release" -v r="$release" '
        $2 == h || index($2, h "-") == 1 {
          sfx = substr($2, length(h) + 1)
          if (sfx != "" && sfx != "-updates" && sfx != "-security") next
          c = ""; for (j = 3; j <= NF; j++) c = c " " $j
          print "deb " $1 " " r sfx c
        }' | sort -u
  )"
  if [ -z "$mirrors" ]; then
    mirrors="deb http://deb.debian.org/debian $release main
deb http://deb.debian.org/debian $release-updates main
deb http://deb.debian.org/debian-security $release-security main"
  fi
  printf '%s\n' "$mirrors"
}

# mmdebstrap's --aptopt options, one a line: apt inside mmdebstrap reads none of this machine's
# apt.conf.d, so its local settings (those no Debian package owns and that run no commands) are passed.
host_aptopts() {
  local f
  echo '--aptopt=Acquire::Retries "3"'
  for f in /etc/apt/apt.conf.d/*; do
    if [ -f "$f" ] && ! dpkg-query -S "$f" >/dev/null 2>&1 && ! grep -q 'Invoke' "$f"; then
      echo "--aptopt=$f"
    fi
  done
}

# This machine's settings that decide which registries it reaches, copied into the root ROOT: CA
# certificates, local apt.conf.d files (those no Debian package owns), pip configuration, DNS.
copy_host_settings() {
  local root="$1" f
  mkdir -p "$root/etc/ssl/certs" "$root/usr/local/share/ca-certificates" "$root/etc/apt/apt.conf.d"
  cp -L /etc/ssl/certs/ca-certificates.crt "$root/etc/ssl/certs/ca-certificates.crt"
  if [ -d /usr/local/share/ca-certificates ]; then
    cp -a /usr/local/share/ca-certificates/. "$root/usr/local/share/ca-certificates/"
  fi
  for f in /etc/apt/apt.conf.d/*; do
    [ -f "$f" ] || continue
    dpkg-query -S "$f" >/dev/null 2>&1 || cp "$f" "$root/etc/apt/apt.conf.d/"
  done
  cp /etc/pip.conf "$root/etc/pip.conf" 2>/dev/null || true
  for f in /etc/xdg/pip /root/.config/pip /root/.pip; do  # with the files a pip.conf names there
    if [ -d "$f" ]; then mkdir -p "$root$f"; cp -a "$f/." "$root$f/"; fi
  done
  cp -L /etc/resolv.conf "$root/etc/resolv.conf" 2>/dev/null || true
}

# Every mount point at or under a folder, deepest first.
mounted_under() { awk -v d="$1/" 'index($2 "/", d) == 1 {print $2}' /proc/mounts | sort -r; }

# Remove a work folder, never through a mount: one still mounted under it keeps the folder (said so).
remove_work() {
  if [ -n "$(mounted_under "$1")" ]; then
    say "NOT deleting $1: something is still mounted under it"
  else
    rm -rf --one-file-system "$1"
  fi
}
