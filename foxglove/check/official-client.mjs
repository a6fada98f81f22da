// usage: node official-client.mjs WS_URL MCAP_FILE [TIMEOUT_SECONDS=120]
// Connects with Foxglove's official client (@foxglove/ws-protocol FoxgloveClient over `ws`),
// subscribes to every advertised channel, counts `message` events per topic, and compares with
// the MCAP file's per-topic message counts. Exit 0 only if every advertised topic's count equals
// the file's, no per-channel timestamp went backwards, and the close code is 1000. A file's
// samples are batched (`rover_power.SampleBatch` on /rover_power/sample_batch, packed columns, its
// first sample's time); the live view sends them one a message on /rover_power/sample, so that
// topic expects one message per sample of every batch, at the batch's time plus the sample's
// `t_s` after the batch's first.
import wsProtocol from "@foxglove/ws-protocol";
const { FoxgloveClient } = wsProtocol;
import { WebSocket } from "ws";
import { McapStreamReader } from "@mcap/core";
import lz4 from "@foxglove/wasm-lz4";
import zstd from "@foxglove/wasm-zstd";
import fs from "node:fs";

const [url, mcapPath, timeoutArg] = process.argv.slice(2);
if (!url || !mcapPath) {
  console.error("usage: node official-client.mjs WS_URL MCAP_FILE [TIMEOUT_SECONDS=120]");
  process.exit(2);
}
const timeoutS = Number(timeoutArg ?? 120);

// ---- expected counts from the MCAP file ----
const SAMPLE = "/rover_power/sample", SAMPLE_BATCH = "/rover_power/sample_batch";
// A SampleBatch's `t_s` column (field 1, packed doubles; unpacked ones read too), in seconds.
function batchTimes(data) {
  const view = new DataView(data.buffer, data.byteOffset, data.byteLength);
  const times = [];
  let i = 0;
  const varint = () => {
    let v = 0n, shift = 0n;
    for (;;) {
      if (i >= data.length) throw new Error("SampleBatch: varint past the end");
      const b = data[i++];
      v |= BigInt(b & 0x7f) << shift; shift += 7n;
      if (!(b & 0x80)) return v;
    }
  };
  while (i < data.length) {
    const key = varint(), field = Number(key >> 3n), wire = Number(key & 7n);
    if (wire === 0) varint();
    else if (wire === 1) { if (field === 1) times.push(view.getFloat64(i, true)); i += 8; }
    else if (wire === 5) i += 4;
    else if (wire === 2) {
      const n = Number(varint());
      if (i + n > data.length) throw new Error("SampleBatch: field past the end");
      if (field === 1) for (let k = i; k + 8 <= i + n; k += 8) times.push(view.getFloat64(k, true));
      i += n;
    } else throw new Error(`SampleBatch: wire type ${wire}`);
  }
  return times;
}
await Promise.all([lz4.isLoaded, zstd.isLoaded]);
const fileCounts = {};
const fileTimes = {}; // topic -> array of logTime (bigint), file order
const batches = { messages: 0, samples: 0 };
{
  const r = new McapStreamReader({
    validateCrcs: true,
    decompressHandlers: {
      lz4: (b, n) => lz4(b, Number(n)),
      zstd: (b, n) => zstd.decompress(b, Number(n)),
    },
  });
  r.append(fs.readFileSync(mcapPath));
  const chans = {};
  let rec;
  while ((rec = r.nextRecord())) {
    if (rec.type === "Channel") chans[rec.id] = rec;
    if (rec.type === "Message") {
      const t = chans[rec.channelId].topic;
      fileCounts[t] = (fileCounts[t] ?? 0) + 1;
      (fileTimes[t] ??= []).push(rec.logTime);
      if (t === SAMPLE_BATCH) {
        const times = batchTimes(rec.data);
        batches.messages++; batches.samples += times.length;
        fileCounts[SAMPLE] = (fileCounts[SAMPLE] ?? 0) + times.length;
        for (const t_s of times) (fileTimes[SAMPLE] ??= []).push(rec.logTime + BigInt(Math.round((t_s - times[0]) * 1e9)));
      }
    }
  }
  if (!r.done()) console.error("warning: MCAP reader did not reach end of file cleanly");
}

// ---- live client ----
const t0 = performance.now();
let tFirstSub = null, tFirstMsg = null, tLastMsg = null;
const ws = new WebSocket(url, [FoxgloveClient.SUPPORTED_SUBPROTOCOL]);
const client = new FoxgloveClient({ ws });

const channelsById = new Map(); // channelId -> channel
const subToChannel = new Map(); // subscriptionId -> channel
const received = {}; // topic -> count
const lastTs = {}; // topic -> last timestamp (bigint)
const backwards = {}; // topic -> count of backwards steps
const firstBackwards = [];
const recvTimes = {}; // topic -> array of timestamps
const statuses = [];
const events = []; // other notable ops in order (serverInfo, unadvertise, removeStatus, time, error)
let serverInfo = null;
let closeCode = null, closeReason = null, closedAt = null, timedOut = false;
let msgTotal = 0;

client.on("open", () => events.push({ t: +((performance.now() - t0) / 1000).toFixed(3), ev: "open", protocol: ws.protocol }));
client.on("error", (e) => events.push({ t: +((performance.now() - t0) / 1000).toFixed(3), ev: "error", error: String(e?.message ?? e) }));
client.on("serverInfo", (si) => { serverInfo = si; });
client.on("status", (s) => statuses.push({ ...s, atSeconds: +((performance.now() - t0) / 1000).toFixed(3), afterMessages: msgTotal }));
client.on("removeStatus", (s) => events.push({ ev: "removeStatus", ...s }));
client.on("unadvertise", (ids) => events.push({ t: +((performance.now() - t0) / 1000).toFixed(3), ev: "unadvertise", ids, afterMessages: msgTotal }));
let timeOps = 0;
client.on("time", () => { timeOps++; });
client.on("advertise", (chs) => {
  events.push({ t: +((performance.now() - t0) / 1000).toFixed(3), ev: "advertise", topics: chs.map((c) => c.topic) });
  for (const ch of chs) {
    channelsById.set(ch.id, ch);
    received[ch.topic] ??= 0;
    const subId = client.subscribe(ch.id);
    subToChannel.set(subId, ch);
    tFirstSub ??= performance.now();
  }
});
client.on("message", (m) => {
  const now = performance.now();
  tFirstMsg ??= now; tLastMsg = now;
  msgTotal++;
  const ch = subToChannel.get(m.subscriptionId);
  const topic = ch ? ch.topic : `?sub${m.subscriptionId}`;
  received[topic] = (received[topic] ?? 0) + 1;
  const ts = m.timestamp;
  if (lastTs[topic] !== undefined && ts < lastTs[topic]) {
    backwards[topic] = (backwards[topic] ?? 0) + 1;
    if (firstBackwards.length < 5) firstBackwards.push({ topic, prev: String(lastTs[topic]), ts: String(ts), index: received[topic] - 1 });
  }
  lastTs[topic] = ts;
  (recvTimes[topic] ??= []).push(ts);
});

const done = new Promise((resolve) => {
  ws.on("close", (code, reason) => {
    closeCode = code;
    closeReason = reason?.toString() ?? "";
    closedAt = performance.now();
    resolve();
  });
});
const timer = setTimeout(() => {
  timedOut = true;
  try { ws.close(4000, "official-client.mjs timeout"); } catch {}
  setTimeout(() => { try { ws.terminate(); } catch {} }, 2000).unref();
}, timeoutS * 1000);
await done;
clearTimeout(timer);

// ---- compare ----
const advertisedTopics = [...new Set([...channelsById.values()].map((c) => c.topic))].sort();
const expected = {}, missing = {};
let countsOk = advertisedTopics.length > 0;
for (const t of advertisedTopics) {
  expected[t] = fileCounts[t] ?? 0;
  missing[t] = expected[t] - (received[t] ?? 0);
  if (missing[t] !== 0) countsOk = false;
}
// informational: the server re-bases timestamps onto wall-clock time and divides by the speed factor.
// Fit recv = recv0 + (file - file0) / K over all advertised topics (file order per topic, sorted)
// and report K and the worst deviation from that line.
let timestampMapping = null;
{
  let file0 = null, fileN = null, recv0 = null, recvN = null;
  const sorted = {};
  for (const t of advertisedTopics) {
    sorted[t] = (fileTimes[t] ?? []).slice().sort((x, y) => (x < y ? -1 : x > y ? 1 : 0));
    for (const v of sorted[t]) { if (file0 === null || v < file0) file0 = v; if (fileN === null || v > fileN) fileN = v; }
    for (const v of recvTimes[t] ?? []) { if (recv0 === null || v < recv0) recv0 = v; if (recvN === null || v > recvN) recvN = v; }
  }
  if (file0 !== null && recv0 !== null && recvN > recv0) {
    const K = Number(fileN - file0) / Number(recvN - recv0);
    let worst = 0, worstAt = null;
    for (const t of advertisedTopics) {
      const a = sorted[t], b = recvTimes[t] ?? [];
      for (let i = 0; i < Math.min(a.length, b.length); i++) {
        const pred = Number(recv0) + Number(a[i] - file0) / K;
        const d = Number(b[i]) - pred;
        if (Math.abs(d) > Math.abs(worst)) { worst = d; worstAt = { topic: t, index: i }; }
      }
    }
    timestampMapping = {
      offsetSeconds: Number(recv0 - file0) / 1e9,
      impliedSpeedK: +K.toFixed(6),
      worstDeviationMicroseconds: +(worst / 1e3).toFixed(3), worstAt,
      receivedSpanSeconds: Number(recvN - recv0) / 1e9, fileSpanSeconds: Number(fileN - file0) / 1e9,
    };
  }
}
const unservedFileTopics = Object.keys(fileCounts).filter((t) => !advertisedTopics.includes(t)).sort();
const unknownReceived = Object.keys(received).filter((t) => !advertisedTopics.includes(t));
const monotonic = Object.keys(backwards).length === 0;
const ok = countsOk && monotonic && closeCode === 1000 && !timedOut && unknownReceived.length === 0;

const sec = (a, b) => (a != null && b != null ? +((b - a) / 1000).toFixed(3) : null);
const summary = {
  url, mcap: mcapPath, ok,
  expected, received, missing,
  sampleBatches: batches,
  totals: {
    expected: Object.values(expected).reduce((x, y) => x + y, 0),
    received: advertisedTopics.reduce((x, t) => x + (received[t] ?? 0), 0),
  },
  unservedFileTopics: Object.fromEntries(unservedFileTopics.map((t) => [t, fileCounts[t]])),
  unknownReceived,
  timestampsMonotonic: monotonic, backwards, firstBackwards,
  timestampMapping,
  statuses, events, timeOps,
  serverInfo: serverInfo && { name: serverInfo.name, capabilities: serverInfo.capabilities, supportedEncodings: serverInfo.supportedEncodings },
  closeCode, closeReason, timedOut,
  seconds: sec(t0, closedAt),
  secondsFirstSubscribeToClose: sec(tFirstSub, closedAt),
  secondsFirstToLastMessage: sec(tFirstMsg, tLastMsg),
  secondsLastMessageToClose: sec(tLastMsg, closedAt),
};
console.log(JSON.stringify(summary, null, 2));
process.exit(ok ? 0 : 1);
