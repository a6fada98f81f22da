#!/usr/bin/env bash
# Builds the release firmware for the STM32F411 (thumbv7em-none-eabihf), checks it fits the
# budget (flash ≤ 64 KiB, static RAM ≤ 16 KiB), prints both figures and writes the raw image
# `target/thumbv7em-none-eabihf/firmware/firmware.bin` for the ROM DFU bootloader
# (profile `firmware`: release, optimised for size).
#
# The toolchain that can build for the board is chosen by firmware/cross-cargo.sh (the pinned one where
# rustup offers the thumbv7em target, else nightly; $CARGO_FW overrides). With CHECK_LINTS=1 the
# firmware is also linted for the target (the RTIC app only compiles there). FW_FEATURES passes
# cargo features, e.g. FW_FEATURES=hse-8mhz for boards with an 8 MHz crystal.
set -euo pipefail
cd "$(dirname "$0")/.."

TARGET=thumbv7em-none-eabihf
FLASH_LIMIT=$((64 * 1024))
RAM_LIMIT=$((16 * 1024))

CARGO_CMD=$(firmware/cross-cargo.sh)
read -r -a CARGO <<<"$CARGO_CMD"
export CARGO_FW="${CARGO[*]}"

FEATURES=()
if [[ -n "${FW_FEATURES:-}" ]]; then FEATURES=(--features "$FW_FEATURES"); fi

if [[ "${CHECK_LINTS:-0}" == 1 ]]; then
    "${CARGO[@]}" clippy -p firmware --bins --profile firmware --target "$TARGET" "${FEATURES[@]}" -- -D warnings
fi
"${CARGO[@]}" build -p firmware --bin firmware --profile firmware --target "$TARGET" "${FEATURES[@]}"

# llvm-size / llvm-objcopy from the pinned toolchain's llvm-tools component.
rustup component list --installed 2>/dev/null | grep -q '^llvm-tools' || rustup component add llvm-tools >/dev/null
LLVM_BIN="$(rustc --print sysroot)/lib/rustlib/$(rustc -vV | sed -n 's/^host: //p')/bin"
# Where cargo put it (CARGO_TARGET_DIR moves the whole target directory).
ELF="${CARGO_TARGET_DIR:-target}/$TARGET/firmware/firmware"

# Flash holds code, read-only data, the vector table and .data's initial values; static RAM is
# .data + .bss + .uninit (the stack grows into the rest).
read -r FLASH RAM < <("$LLVM_BIN/llvm-size" -A "$ELF" | awk '
    $1 == ".vector_table" || $1 == ".text" || $1 == ".rodata" { flash += $2 }
    $1 == ".data" { flash += $2; ram += $2 }
    $1 == ".bss" || $1 == ".uninit" { ram += $2 }
    END { print flash, ram }')
VECTORS=$("$LLVM_BIN/llvm-size" -A -x "$ELF" | awk '$1 == ".vector_table" { print $3 }')
"$LLVM_BIN/llvm-objcopy" -O binary "$ELF" "$ELF.bin"

awk -v f="$FLASH" -v r="$RAM" -v fl="$FLASH_LIMIT" -v rl="$RAM_LIMIT" 'BEGIN {
    printf "firmware flash: %d bytes (%.1f KiB of %d KiB budget)\n", f, f / 1024, fl / 1024
    printf "firmware static RAM: %d bytes (%.1f KiB of %d KiB budget)\n", r, r / 1024, rl / 1024 }'
echo "vector table at $VECTORS; DFU image: $ELF.bin"

status=0
if [[ "$VECTORS" != "0x8000000" ]]; then
    echo "error: vector table at $VECTORS, expected 0x8000000 (is -Tlink.x missing?)" >&2
    status=1
fi
if (( FLASH > FLASH_LIMIT )); then echo "error: flash over budget" >&2; status=1; fi
if (( RAM > RAM_LIMIT )); then echo "error: static RAM over budget" >&2; status=1; fi
exit $status
