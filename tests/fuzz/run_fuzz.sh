#!/bin/sh
# Short libFuzzer run of one target from its committed seed corpus (read-only: new inputs go to
# a temporary directory that is removed afterwards). Exit status: libFuzzer's (non-zero on a
# crash, a sanitizer report, a leak or a timeout of one input).
#   run_fuzz.sh BINARY CORPUS_DIR RUNS SECONDS
set -eu
bin="$1"; corpus="$2"; runs="$3"; seconds="$4"
work=$(mktemp -d "${TMPDIR:-/tmp}/hexa_fuzz.XXXXXX")
trap 'rm -rf "$work"' EXIT INT TERM
cd "$work"
"$bin" -runs="$runs" -max_total_time="$seconds" -timeout=10 -rss_limit_mb=2048 \
  -print_final_stats=1 "$work" "$corpus"
