#!/usr/bin/env bash
# The Debian package against the product: every hexa_* program of the build tree in /usr/bin
# with its manual page, every page of docs/ and the README, the Foxglove layout, the plot
# scripts, the rig and DDS configurations; its file name as docs/deployment.md gives it. Then
# unpacks it into a scratch root (dpkg -x) and runs programs from there with the packaged files.
# Usage: check_deb.sh SOURCE_DIR BUILD_DIR [DEB]; DEB defaults to the newest
# SOURCE_DIR/build-deb/hexataar-control_*.deb (scripts/build_deb.sh). Exit 77 (skipped) when
# DEB is not given and there is no package to check; a DEB given but missing is a failure.
set -uo pipefail
src="$1"
build="$2"
if [ -n "${3:-}" ] && [ ! -f "$3" ]; then
  echo "FAIL: no package at $3"
  exit 1
fi
deb="${3:-$(ls -t "$src"/build-deb/hexataar-control_*.deb 2>/dev/null | head -n 1)}"
if [ -z "$deb" ] || [ ! -f "$deb" ]; then
  echo "SKIP: no package; build it with scripts/build_deb.sh"
  exit 77
fi
echo "package: $deb"
fail=0
bad() { echo "FAIL: $*"; fail=1; }
contents="$(dpkg-deb -c "$deb" | awk '{print $6}' | sed 's|^\./|/|')"
has() { grep -qx -- "$1" <<<"$contents"; }

documented="$(grep -o 'hexataar-control_[0-9.]*-[0-9]*_amd64\.deb' "$src/docs/deployment.md" | sort -u)"
[ "$(wc -l <<<"$documented")" = 1 ] || bad "docs/deployment.md names the package in more than one way: $documented"
[ "$(basename "$deb")" = "$documented" ] || bad "file name $(basename "$deb"), docs/deployment.md says $documented"

programs=$(find "$build" -path "$build/tests" -prune -o -path "$build/bench" -prune -o \
  -path "$build/build-deb" -prune -o -type f -perm -u+x -name 'hexa_*' -print | xargs -n1 basename | sort -u)
[ -n "$programs" ] || bad "no hexa_* program in $build"
for p in $programs; do
  has "/usr/bin/$p" || bad "program $p is not in /usr/bin"
  has "/usr/share/man/man1/$p.1.gz" || bad "program $p has no manual page"
done
doc=/usr/share/doc/hexataar-control
for f in $(cd "$src" && find docs -name '*.md'); do
  has "$doc/$f" || bad "$f is not in $doc/"
done
for f in "$doc/README.md" "$doc/copyright" /usr/share/hexa/foxglove/hexataar.layout.json \
         /usr/share/hexa/deploy/plot_session.py /usr/share/hexa/tools/identify/plot_identification.py \
         /usr/share/hexa/deploy/cueing/washout.textproto \
         /usr/share/hexa/cyclonedds-loopback.xml /etc/hexa/rig.textproto; do
  has "$f" || bad "$f is missing"
done
echo "checked $(wc -w <<<"$programs") programs, $(cd "$src" && find docs -name '*.md' | wc -l) pages of docs/"

root="$(mktemp -d)"
trap 'rm -rf "$root"' EXIT
dpkg -x "$deb" "$root" || bad "dpkg -x failed"
run() {  # run NAME PATTERN COMMAND...: exit 0 and PATTERN in the output
  local name="$1" pattern="$2"
  shift 2
  local out
  out="$("$@" 2>&1)"
  local rc=$?
  if [ $rc -ne 0 ] || ! grep -q -- "$pattern" <<<"$out"; then
    bad "$name (exit $rc):"
    tail -n 15 <<<"$out"
  else
    echo "ok: $name"
  fi
}
bin="$root/usr/bin"
run "hexa_session --help" "--trajectory" "$bin/hexa_session" --help
run "hexa_calibrate --help" "--truth-seed" "$bin/hexa_calibrate" --help
run "hexa_identify --help" "--rig-overlay" "$bin/hexa_identify" --help
# An in-process session on the packaged rig file (the default /etc/hexa/rig.textproto is the
# installed one; here the unpacked copy).
run "hexa_sim --trajectory z --periods 1" "RMSE" "$bin/hexa_sim" --rig "$root/etc/hexa/rig.textproto" \
  --trajectory z --periods 1
run "hexa_check_config on the packaged rig" "OK" "$bin/hexa_check_config" "$root/etc/hexa/rig.textproto"
exit $fail
