#!/usr/bin/env bash
# On-target test of model-core: builds the `model-core-qemu` bin for the Cortex-M4F, runs its
# checks under QEMU's netduinoplus2 (STM32F405, semihosting for output and exit status), then
# runs it again with an instruction trace and counts the instructions executed per sample between
# the bench markers.
#
# Environment:
#   CARGO_FW      cargo command prefix for the cross build (default: firmware/cross-cargo.sh)
#   QEMU_PROFILE  cargo profile (default `firmware`: the board image's size-optimised code;
#                 `release` shows what opt-level 3 would do)
#   QEMU          qemu binary (default qemu-system-arm; CI: apt-get install -y qemu-system-arm)
#   QEMU_TIMEOUT  seconds per QEMU run (default 60)
#   LLVM_NM       llvm-nm (default: the host toolchain's llvm-tools component)
set -euo pipefail

start=$SECONDS
here=$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)
cd "$here/.."

target=thumbv7em-none-eabihf
bin=model-core-qemu
cargo_cmd=$(firmware/cross-cargo.sh)
read -r -a cargo_fw <<<"$cargo_cmd"
profile=${QEMU_PROFILE:-firmware}
qemu=${QEMU:-qemu-system-arm}
qemu_timeout=${QEMU_TIMEOUT:-60}
tools="$(rustc --print sysroot)/lib/rustlib/$(rustc -vV | sed -n 's/^host: //p')/bin"
nm=${LLVM_NM:-$tools/llvm-nm}

work=$(mktemp -d "${TMPDIR:-/tmp}/qemu-model-core.XXXXXX")
trap 'rm -rf "$work"' EXIT

echo "== build: ${cargo_fw[*]} build --profile $profile --target $target -p firmware --bin $bin"
"${cargo_fw[@]}" build --profile "$profile" --target "$target" -p firmware --bin "$bin" \
    --message-format=json-render-diagnostics >"$work/build.json"
elf=$(sed -n 's/.*"executable":"\([^"]*\)".*/\1/p' "$work/build.json" | tail -n 1)
if [[ -z $elf || ! -f $elf ]]; then
    echo "error: cargo reported no executable for $bin" >&2
    exit 1
fi
echo "elf: $elf"

qemu_args=(-machine netduinoplus2 -cpu cortex-m4 -nographic
    -semihosting-config enable=on,target=native)
# One guest instruction per translation block, so that each exec trace line is one instruction:
# `-one-insn-per-tb` since QEMU 8.1, `-singlestep` before (deprecated in 8.1).
# (Help text captured first: `qemu -help | grep -q` could fail on SIGPIPE under pipefail.)
qemu_help=$("$qemu" -help)
if grep -q -- '^-one-insn-per-tb' <<<"$qemu_help"; then
    one_insn=(-one-insn-per-tb)
else
    one_insn=(-singlestep)
fi
qemu_version=$("$qemu" --version)
echo "${qemu_version%%$'\n'*}"

echo "== checks on the target"
status=0
timeout "$qemu_timeout" "$qemu" "${qemu_args[@]}" -kernel "$elf" | tee "$work/run.log" ||
    status=$?
fail_status() {
    if [[ $2 -eq 124 ]]; then
        echo "FAILED: $1 timed out after ${qemu_timeout}s" >&2
    else
        echo "FAILED: $1 exited with status $2" >&2
    fi
    exit 1
}
[[ $status -eq 0 ]] || fail_status "qemu" "$status"
if ! grep -Eq '^([0-9]+) of \1 checks passed$' "$work/run.log"; then
    echo "FAILED: no 'N of N checks passed' line in the output" >&2
    exit 1
fi
echo "checks: passed (qemu exit status 0)"
# Iterations of each bench loop, as the bin reports them (`K` in src/bin/model_core_qemu.rs).
k=$(sed -n 's/^bench update only: *K = \([0-9]*\),.*/\1/p' "$work/run.log")
if [[ -z $k || $k -eq 0 ]]; then
    echo "error: the bin did not report its bench K" >&2
    exit 1
fi

echo "== instruction count: ${one_insn[*]} -d exec,nochain, K = $k"
# Marker addresses without the Thumb bit and leading zeros (QEMU logs PCs zero-padded to its own
# width), lower case.
addr() {
    local a
    a=$("$nm" "$elf" | awk -v s="$1" '$3 == s { print $1 }')
    if [[ -z $a ]]; then
        echo "error: symbol $1 not found in $elf" >&2
        exit 1
    fi
    printf '%x\n' $((0x$a & ~1))
}
b1=$(addr bench_begin)
e1=$(addr bench_end)
b2=$(addr bench_update_begin)
e2=$(addr bench_update_end)
b3=$(addr bench_inputs_begin)
e3=$(addr bench_inputs_end)
b4=$(addr bench_i2c_begin)
e4=$(addr bench_i2c_end)
if [[ $(printf '%s\n' "$b1" "$e1" "$b2" "$e2" "$b3" "$e3" "$b4" "$e4" | sort -u | wc -l) -ne 8 ]]; then
    echo "error: bench markers share addresses: folded by the compiler or linker?" >&2
    exit 1
fi
echo "markers: bench_begin 0x$b1 bench_end 0x$e1 bench_update_begin 0x$b2" \
    "bench_update_end 0x$e2 bench_inputs_begin 0x$b3 bench_inputs_end 0x$e3" \
    "bench_i2c_begin 0x$b4 bench_i2c_end 0x$e4"

# A symbol-less copy keeps the trace lines short (QEMU appends the symbol name to every line).
"$tools/llvm-objcopy" --strip-all "$elf" "$work/trace.elf"
trace="$work/exec.trace"
status=0
timeout "$qemu_timeout" "$qemu" "${qemu_args[@]}" "${one_insn[@]}" -d exec,nochain -D "$trace" \
    -kernel "$work/trace.elf" >/dev/null || status=$?
[[ $status -eq 0 ]] || fail_status "traced qemu run" "$status"
echo "trace: $(wc -l <"$trace") lines, $(du -h "$trace" | cut -f1)"

# Each "Trace" line is one executed translation block = one guest instruction (checked against a
# 2 + 2 x 100 instruction asm loop: exact). Counted per marker pair: the lines after the first
# instruction of the begin marker up to (not including) the first instruction of its end marker,
# i.e. the K iterations plus about ten instructions of marker return and loop set-up.
read -r n1 n2 n3 n4 <<<"$(awk -v b="$b1 $b2 $b3 $b4" -v e="$e1 $e2 $e3 $e4" '
    BEGIN { np = split(b, begin, " "); split(e, end, " ") }
    /^Trace / {
        s = substr($0, index($0, "[") + 1)
        split(s, f, "/")
        pc = tolower(f[2])
        sub(/^0+/, "", pc)
        for (i = 1; i <= np; i++) {
            if (st[i] == 1) { if (pc == end[i]) st[i] = 2; else n[i]++ }
            else if (st[i] == 0 && pc == begin[i]) st[i] = 1
        }
    }
    END { for (i = 1; i <= np; i++) printf "%d ", (st[i] == 2 ? n[i] : -1); print "" }
' "$trace")"
rm -f "$trace"
if [[ $n1 -lt 0 || $n2 -lt 0 || $n3 -lt 0 || $n4 -lt 0 ]]; then
    echo "error: a bench marker pair was not found in the trace" >&2
    exit 1
fi
echo "instructions between markers (K = $k): update+encode $n1, update only $n2," \
    "loop and inputs only $n3"
awk -v n1="$n1" -v n2="$n2" -v n3="$n3" -v n4="$n4" -v k="$k" 'BEGIN {
    printf "instructions per sample: update+encode %.1f, update only %.1f\n", n1 / k, n2 / k
    printf "  (both include deriving current and power from shunt and bus (Eq 3-4), the bench\n"
    printf "  loop and making the shunt and bus reads: %.1f per sample alone)\n", n3 / k
    printf "I2C interrupt handler per sample (both chips: 2 short + 2 pointed reads, 18 handler\n"
    printf "  runs, with begin and end of each transfer): %.1f instructions (%.1f per handler run;\n", 2 * n4 / k, n4 / k / 9
    printf "  register accesses as plain memory, interrupt entry and exit not included)\n"
}'
echo "done in $((SECONDS - start)) s"
