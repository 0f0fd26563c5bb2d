#!/usr/bin/env bash
# SPDX-License-Identifier: Apache-2.0
# Prints, one per line, the Debian packages that hold the shared libraries the given binaries
# load (what dpkg-shlibdeps would compute, without dpkg-dev): deploy/Containerfile's runtime stage
# installs exactly these, so that it carries no -dev package and no library a binary does not use.
#
#   deploy/runtime-packages.sh build/server/nearpointd build/client/nearpoint
#
# Fails (exit 1, naming the library) when a library is missing or belongs to no package: an image
# built from such a list would fail at run time instead.
set -euo pipefail
if [ $# -eq 0 ]; then
  echo "usage: deploy/runtime-packages.sh BINARY..." >&2
  exit 2
fi

# The package that owns a file. Debian 12 is merged-/usr: ldd may name /lib/... where dpkg
# registered /usr/lib/... (or the other way round), so each spelling is asked for.
owner() {
  local path="$1" real
  real="$(readlink -f "$path")"
  for candidate in "$path" "$real" "/usr${path#/usr}" "${path#/usr}" "/usr${real#/usr}" "${real#/usr}"; do
    if dpkg-query -S "$candidate" 2>/dev/null | head -n 1 | cut -d: -f1; then return 0; fi
  done
  return 1
}

# "libfoo.so.1 => /usr/lib/.../libfoo.so.1 (0x…)", or "libfoo.so.1 => not found".
listing="$(ldd "$@")"
missing="$(awk '$2 == "=>" && $3 == "not" { print $1 }' <<<"$listing" | sort -u)"
if [ -n "$missing" ]; then
  echo "runtime-packages: not found by ldd: $missing" >&2
  exit 1
fi
packages=()
while read -r library; do
  if ! package="$(owner "$library")"; then
    echo "runtime-packages: no Debian package holds $library" >&2
    exit 1
  fi
  packages+=("$package")
done < <(awk '$2 == "=>" && $3 ~ /^\// { print $3 }' <<<"$listing" | sort -u)
printf '%s\n' "${packages[@]}" | sort -u
