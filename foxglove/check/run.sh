#!/usr/bin/env bash
# Our layout (foxglove/rover-power.json) in the real Foxglove Studio, in a real browser: the
# open-source Studio 1.48 from the npm registry (@foxglove/studio-base's built bundle), served on
# 127.0.0.1 and driven by Debian's Chromium through Playwright. First, every ros2msg schema of the
# ROS 2 bags we write (`convert --to ros2-bag` of the demo's log, `demo --robot-bag`) through
# Foxglove's own parser (ros2msg-schemas.mjs). Then three checks, each bounded in time:
#   1. a demo run's MCAP log opened in Studio as a file;
#   2. the same log served by `host-tool replay --serve` to Foxglove's own client library, which
#      must receive every message and a normal close;
#   3. the same log served live to Studio.
# The Studio checks fail unless every panel of the layout shows data and Studio lists no
# problem. The JSON
# summaries and screenshots go to OUT_DIR (default: a new temporary directory), never the tree.
#
#   foxglove/check/run.sh [OUT_DIR]      (HOST_TOOL=path/to/host-tool to use another build)
set -euo pipefail
HERE="$(cd "$(dirname "$0")" && pwd)"
ROOT="$(cd "$HERE/../.." && pwd)"
HOST_TOOL="${HOST_TOOL:-${CARGO_TARGET_DIR:-$ROOT/target}/release/host-tool}"
OUT="${1:-$(mktemp -d)}"
mkdir -p "$OUT"

if ! command -v chromium >/dev/null; then
    apt-get update -qq
    DEBIAN_FRONTEND=noninteractive apt-get install -y -qq chromium >/dev/null
fi
(cd "$HERE" && npm ci --no-audit --no-fund --loglevel=error)

rm -rf "$OUT/demo"
"$HOST_TOOL" demo --runs 1 --out "$OUT/demo" >"$OUT/demo.log" 2>&1
LOG="$OUT/demo/run-1.mcap"
LAYOUT="$ROOT/foxglove/rover-power.json"

rm -rf "$OUT/ros2-bag" "$OUT/robot-bags"
"$HOST_TOOL" convert "$LOG" "$OUT/ros2-bag" --to ros2-bag >"$OUT/ros2-bag.log" 2>&1 ||
    { cat "$OUT/ros2-bag.log"; exit 1; }
"$HOST_TOOL" demo --runs 1 --robot-bag --out "$OUT/robot-bags" >"$OUT/robot-bags.log" 2>&1 ||
    { cat "$OUT/robot-bags.log"; exit 1; }
echo "ros2msg schemas, @foxglove/rosmsg (ROS 2 mode): $OUT/ros2-bag $OUT/robot-bags"
node "$HERE/ros2msg-schemas.mjs" "$OUT/ros2-bag" "$OUT/robot-bags"

echo "Foxglove Studio, file: $LOG"
node "$HERE/check.mjs" --mcap "$LOG" --layout "$LAYOUT" --screenshot "$OUT/studio-file.png" \
    --timeout 120 >"$OUT/studio-file.json" || { cat "$OUT/studio-file.json"; exit 1; }

# Serves the log live at SPEED; sets URL and REPLAY (its process).
serve() {
    : >"$OUT/replay.addr"
    "$HOST_TOOL" replay "$LOG" --serve 127.0.0.1:0 --speed "$1" >"$OUT/replay.addr" \
        2>"$OUT/replay-$1x.log" &
    REPLAY=$!
    for _ in $(seq 100); do
        [ -s "$OUT/replay.addr" ] && break
        sleep 0.1
    done
    URL=$(head -n1 "$OUT/replay.addr")
}
trap 'kill ${REPLAY:-} 2>/dev/null || true' EXIT

# Foxglove's own WebSocket client (@foxglove/ws-protocol) gets every message the log holds on
# the served topics, in time order, and a normal close.
serve 25
echo "official Foxglove client, live at 25x: $URL"
node "$HERE/official-client.mjs" "$URL" "$LOG" 60 >"$OUT/official-client.json" ||
    { cat "$OUT/official-client.json"; exit 1; }
wait "$REPLAY"

# Studio live: at real time the 48 s run outlasts the check, so every panel is seen filling.
serve 1
echo "Foxglove Studio, live: $URL"
node "$HERE/check.mjs" --ws "$URL" --layout "$LAYOUT" --screenshot "$OUT/studio-live.png" \
    --timeout 120 >"$OUT/studio-live.json" || { cat "$OUT/studio-live.json"; exit 1; }
kill "$REPLAY" 2>/dev/null || true

node -e '
for (const f of process.argv.slice(1)) {
  const s = require(f);
  const panels = s.panels.map((p) => `${p.id} ${p.status}${p.seriesWithValue ? " " + p.seriesWithValue : ""}${p.coloredPixels !== undefined ? " " + p.coloredPixels + " px" : ""}${p.rows !== undefined ? " " + p.rows + " rows" : ""}`);
  console.log(`${f}: ok=${s.ok} problems=${s.problems.length} ${(s.timing.totalMs / 1000).toFixed(1)} s\n  ${panels.join("\n  ")}`);
}
const c = require(process.argv[1].replace("studio-file", "official-client"));
console.log(`official client: ${c.totals.received} of ${c.totals.expected} messages, close ${c.closeCode}`);
' "$OUT/studio-file.json" "$OUT/studio-live.json"
echo "screenshots: $OUT/studio-file.png $OUT/studio-live.png"
