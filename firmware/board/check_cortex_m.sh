#!/bin/sh
# Cross-compiles the board's C code for a Cortex-M4 (Debian's gcc-arm-none-eabi) as firmware
# would build it: C99, freestanding, warnings as errors. Fails if it does not build, or if the
# objects need anything from outside but the compiler's memcpy/memset (no heap, no OS calls,
# no stdio). Exit 77 (skipped) only when the cross compiler is not installed.
#   check_cortex_m.sh BOARD_SOURCE_DIR [WORK_DIR]
set -eu
src="$1"
cc="${HEXA_ARM_CC:-arm-none-eabi-gcc}"
nm="${HEXA_ARM_NM:-arm-none-eabi-nm}"
if ! command -v "$cc" >/dev/null 2>&1; then
  echo "board.CortexM4Build: skipped: $cc not found (apt-get install gcc-arm-none-eabi; scripts/install_deps.sh)"
  exit 77
fi
work="${2:-$(mktemp -d "${TMPDIR:-/tmp}/hexa_board_arm.XXXXXX")}"
mkdir -p "$work"
flags="-std=c99 -mcpu=cortex-m4 -mthumb -mfloat-abi=soft -ffreestanding -Os -Wall -Wextra -Wpedantic -Wconversion -Wshadow -Werror"
objects=""
for c in "$src"/src/*.c; do
  o="$work/$(basename "$c" .c).o"
  objects="$objects $o"
  echo "$cc $flags -I$src/include -c $c -o $o"
  # shellcheck disable=SC2086
  "$cc" $flags -I"$src/include" -c "$c" -o "$o"
done
# One relocatable object: what the board code calls among its own files is resolved.
# shellcheck disable=SC2086
"${HEXA_ARM_LD:-arm-none-eabi-ld}" -r $objects -o "$work/hexa_board.o"
undefined=$("$nm" -u "$work/hexa_board.o" | awk '{ print $NF }' | sort -u | grep -v -x -e memcpy -e memset || true)
if [ -n "$undefined" ]; then
  echo "board.CortexM4Build: the board code needs symbols a bare-metal build does not have:" >&2
  echo "$undefined" >&2
  exit 1
fi
"${HEXA_ARM_SIZE:-arm-none-eabi-size}" "$work/hexa_board.o"
echo "board.CortexM4Build: OK ($("$cc" --version | head -n 1))"
