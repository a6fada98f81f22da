#!/usr/bin/env bash
# Prints the cargo command that can build for thumbv7em-none-eabihf, installing the target's
# standard library if needed: `cargo` when the pinned rust-toolchain.toml channel offers it,
# else `cargo +nightly` (some Rust mirrors carry thumbv7em only for the installed nightly).
# $CARGO_FW, when set, wins.
set -euo pipefail
TARGET=thumbv7em-none-eabihf
if [[ -n "${CARGO_FW:-}" ]]; then
    echo "$CARGO_FW"
    exit 0
fi
has_target() { rustup "$@" target list --installed 2>/dev/null | grep -qx "$TARGET"; }
if has_target || rustup target add "$TARGET" >/dev/null 2>&1; then
    echo "cargo"
elif has_target +nightly || rustup +nightly target add "$TARGET" >/dev/null 2>&1; then
    echo "note: the pinned toolchain has no $TARGET standard library here; using nightly" >&2
    echo "cargo +nightly"
else
    echo "error: no installed toolchain can get the $TARGET standard library (rustup target add failed)" >&2
    exit 1
fi
