// usage: node ros2msg-schemas.mjs PATH...   (an MCAP file, or a directory searched for them)
// Parses every `ros2msg` schema of the MCAP files with Foxglove's own parser, as Studio 1.48
// does (@foxglove/rosmsg 4.2.1, `parse(text, { ros2: true })`), and builds its CDR reader from
// the result (@foxglove/rosmsg2-serialization, which Studio decodes messages with), so that a
// schema Studio cannot use fails here. Prints one line per schema; exit 0 only if every
// schema parses and at least one was found (an input without any proves nothing); exit 1
// otherwise, 2 on a usage or read error.
import { parse } from "@foxglove/rosmsg";
import { MessageReader } from "@foxglove/rosmsg2-serialization";
import { McapStreamReader } from "@mcap/core";
import lz4 from "@foxglove/wasm-lz4";
import zstd from "@foxglove/wasm-zstd";
import fs from "node:fs";
import path from "node:path";

const inputs = process.argv.slice(2);
if (inputs.length === 0) {
  console.error("usage: node ros2msg-schemas.mjs PATH...");
  process.exit(2);
}

function mcapFiles(p) {
  if (!fs.statSync(p).isDirectory()) return [p];
  return fs
    .readdirSync(p, { withFileTypes: true })
    .flatMap((e) => (e.isDirectory() ? mcapFiles(path.join(p, e.name)) : e.name.endsWith(".mcap") ? [path.join(p, e.name)] : []))
    .sort();
}

await Promise.all([lz4.isLoaded, zstd.isLoaded]);
let checked = 0;
let failed = 0;
for (const file of inputs.flatMap(mcapFiles)) {
  const reader = new McapStreamReader({
    validateCrcs: true,
    decompressHandlers: {
      lz4: (b, n) => lz4(b, Number(n)),
      zstd: (b, n) => zstd.decompress(b, Number(n)),
    },
  });
  reader.append(fs.readFileSync(file));
  const schemas = new Map(); // id -> Schema record
  const topics = new Map(); // schema id -> the topics using it (a Set: the summary repeats channels)
  const messages = new Map(); // schema id -> first message on it
  const channels = new Map(); // channel id -> schema id
  let rec;
  while ((rec = reader.nextRecord())) {
    if (rec.type === "Schema") schemas.set(rec.id, rec);
    if (rec.type === "Channel") {
      channels.set(rec.id, rec.schemaId);
      (topics.get(rec.schemaId) ?? topics.set(rec.schemaId, new Set()).get(rec.schemaId)).add(rec.topic);
    }
    if (rec.type === "Message") {
      const id = channels.get(rec.channelId);
      if (!messages.has(id)) messages.set(id, rec.data);
    }
  }
  if (!reader.done()) {
    console.error(`${file}: the MCAP reader did not reach the end of the file`);
    process.exit(2);
  }
  for (const [id, schema] of schemas) {
    if (schema.encoding !== "ros2msg") continue;
    checked++;
    const where = `${file}: ${schema.name} (${[...(topics.get(id) ?? [])].join(", ")})`;
    try {
      const definitions = parse(new TextDecoder().decode(schema.data), { ros2: true });
      const first = messages.get(id);
      // Decoding one message proves the parsed fields line up with the bytes we wrote.
      if (first) new MessageReader(definitions).readMessage(first);
      console.log(`ok ${where}${first ? ", a message decoded" : ""}`);
    } catch (e) {
      failed++;
      console.log(`FAIL ${where}: ${e?.message ?? e}`);
    }
  }
}
if (checked === 0) {
  console.log("FAIL no ros2msg schema in", inputs.join(" "));
  process.exit(1);
}
console.log(`${checked - failed} of ${checked} ros2msg schemas parse with @foxglove/rosmsg (ROS 2 mode)`);
process.exit(failed === 0 ? 0 : 1);
