#!/usr/bin/env bash
# System set-up for the tests (run by `make test`; idempotent, quick when everything is there).
#  * the Debian packages in setup/debian-packages.txt (apt-get, as root);
#  * OpenCV's sample clip vtest.avi, taken from Debian's opencv-doc package into
#    .cache/opencv-doc/vtest.avi (the .deb is downloaded once and only that file extracted).
# Without root (or apt) it says what is missing and goes on: the tests that need it skip,
# except under LOOKAHEAD_REQUIRE_SYSTEM=1 (set by `make test`), where they fail.
set -uo pipefail
cd "$(dirname "$0")/.."
mapfile -t want < <(sed -e 's/#.*//' -e 's/[[:space:]]//g' setup/debian-packages.txt | grep -v '^$')
missing=()
for p in "${want[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
can_apt=0
if [ "$(id -u)" = 0 ] && command -v apt-get >/dev/null; then can_apt=1; fi
if [ ${#missing[@]} -gt 0 ]; then
  if [ $can_apt = 1 ]; then
    echo "setup: installing ${missing[*]}"
    export DEBIAN_FRONTEND=noninteractive
    apt-get install -y -q --no-install-recommends "${missing[@]}" >/dev/null 2>&1 \
      || { apt-get update -q >/dev/null 2>&1 && apt-get install -y -q --no-install-recommends "${missing[@]}" >/dev/null; } \
      || echo "setup: could not install ${missing[*]}"
  else
    echo "setup: missing Debian packages ${missing[*]} (run setup/system.sh as root)"
  fi
fi
clip=.cache/opencv-doc/vtest.avi
if [ ! -s "$clip" ]; then
  if [ -s /usr/share/doc/opencv-doc/examples/data/vtest.avi ]; then
    mkdir -p "$(dirname "$clip")" && cp /usr/share/doc/opencv-doc/examples/data/vtest.avi "$clip"
  elif command -v apt-get >/dev/null; then
    tmp=$(mktemp -d)
    if (cd "$tmp" && apt-get download -q opencv-doc >/dev/null 2>&1); then
      mkdir -p "$(dirname "$clip")"
      dpkg-deb --fsys-tarfile "$tmp"/opencv-doc_*.deb \
        | tar -xO ./usr/share/doc/opencv-doc/examples/data/vtest.avi > "$clip.part" && mv "$clip.part" "$clip"
    else
      echo "setup: could not download Debian's opencv-doc (for $clip)"
    fi
    rm -rf "$tmp"
  fi
fi
exit 0
