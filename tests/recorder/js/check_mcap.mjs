// Independent check of a hexa_recorder MCAP file with code nobody in this project wrote: the
// MCAP project's TypeScript library (@mcap/core) and protobufjs.
//   node check_mcap.mjs FILE.mcap HEXA_RECORDER_BINARY
// 1. McapIndexedReader (footer -> summary -> chunk indexes -> message indexes) lists channels
//    and schemas and reads every message with CRC validation.
// 2. Each schema's FileDescriptorSet is loaded into protobufjs and every message is decoded.
// 3. McapStreamReader walks the whole file record by record (CRC validation on).
// 4. Every per-topic count and the total agree with `hexa_recorder info`.
// Prints "N passed, M failed" and exits non-zero on any failure.
import { createRequire } from "node:module";
import { execFileSync } from "node:child_process";
import { readFileSync } from "node:fs";
import { McapIndexedReader, McapStreamReader } from "@mcap/core";

const require = createRequire(import.meta.url);
const protobuf = require("protobufjs");
const descriptor = require("protobufjs/ext/descriptor");

const [file, recorderBin] = process.argv.slice(2);
if (!file || !recorderBin) {
  console.error("usage: node check_mcap.mjs FILE.mcap HEXA_RECORDER_BINARY");
  process.exit(2);
}

let passed = 0;
let failed = 0;
function check(ok, what) {
  if (ok) {
    passed += 1;
  } else {
    failed += 1;
    console.error(`FAIL: ${what}`);
  }
}

const bytes = new Uint8Array(readFileSync(file));
const readable = {
  size: async () => BigInt(bytes.length),
  read: async (offset, size) => bytes.subarray(Number(offset), Number(offset + size)),
};

// ---- 1 + 2: indexed reader and protobuf decoding -------------------------------------------
const reader = await McapIndexedReader.Initialize({ readable });
const typesBySchema = new Map();
for (const [id, schema] of reader.schemasById) {
  check(schema.encoding === "protobuf", `schema ${id} encoding '${schema.encoding}' is protobuf`);
  const set = descriptor.FileDescriptorSet.decode(schema.data);
  const root = protobuf.Root.fromDescriptor(set);
  const type = root.lookupType(schema.name);
  check(type !== null, `schema ${id} '${schema.name}' found in its FileDescriptorSet`);
  typesBySchema.set(id, type);
}
const jsCounts = new Map();
for (const [, ch] of reader.channelsById) {
  check(ch.messageEncoding === "protobuf", `channel '${ch.topic}' message encoding protobuf`);
  check(ch.metadata.has("hexa.type"), `channel '${ch.topic}' carries hexa.type metadata`);
  jsCounts.set(ch.topic, 0);
}
let decodeFailures = 0;
let tickFailures = 0;
let total = 0;
for await (const msg of reader.readMessages({ validateCrcs: true })) {
  const ch = reader.channelsById.get(msg.channelId);
  const type = typesBySchema.get(ch.schemaId);
  let decoded;
  try {
    decoded = type.decode(msg.data);
  } catch (e) {
    decodeFailures += 1;
    continue;
  }
  const obj = type.toObject(decoded, { longs: String, enums: String, defaults: true });
  // Every time-stamped type has a header whose source time is the MCAP publish time.
  if (obj.header !== undefined) {
    if (BigInt(obj.header.source_time_ns) !== msg.publishTime || BigInt(obj.header.tick) <= 0n) {
      tickFailures += 1;
    }
  }
  jsCounts.set(ch.topic, jsCounts.get(ch.topic) + 1);
  total += 1;
}
check(decodeFailures === 0, `${decodeFailures} messages failed to decode with protobufjs`);
check(tickFailures === 0, `${tickFailures} messages with header.source_time_ns != publish_time`);
check(reader.statistics !== undefined, "summary has a Statistics record");
check(BigInt(total) === reader.statistics.messageCount,
      `indexed read ${total} messages == statistics ${reader.statistics.messageCount}`);
check(reader.chunkIndexes.length === reader.statistics.chunkCount,
      `chunk indexes ${reader.chunkIndexes.length} == statistics chunk count`);

// ---- 3: streaming reader over the whole file ---------------------------------------------
const stream = new McapStreamReader({ validateCrcs: true });
stream.append(bytes);
const streamCounts = new Map();
const streamChannels = new Map();
let sawFooter = false;
let sawDataEnd = false;
for (let rec; (rec = stream.nextRecord()); ) {
  if (rec.type === "Channel") streamChannels.set(rec.id, rec.topic);
  if (rec.type === "Message") {
    const topic = streamChannels.get(rec.channelId);
    streamCounts.set(topic, (streamCounts.get(topic) ?? 0) + 1);
  }
  if (rec.type === "DataEnd") sawDataEnd = true;
  if (rec.type === "Footer") sawFooter = true;
}
check(stream.done(), "stream reader consumed the whole file");
check(sawDataEnd && sawFooter, "stream reader saw DataEnd and Footer");
for (const [topic, n] of jsCounts) {
  check(streamCounts.get(topic) === n, `'${topic}': stream ${streamCounts.get(topic)} == indexed ${n}`);
}

// ---- 4: agreement with `hexa_recorder info` --------------------------------------------
const info = execFileSync(recorderBin, ["info", file], { encoding: "utf8" });
const infoCounts = new Map();
let infoTotal = -1;
for (const line of info.split("\n")) {
  const m = line.match(/^(\d+)\s+(\S+)\s+(\S+)\s+(\d+)\s/);
  if (m) infoCounts.set(m[2], Number(m[4]));
  const t = line.match(/^messages:\s+(\d+) in/);
  if (t) infoTotal = Number(t[1]);
}
check(infoCounts.size === jsCounts.size,
      `info lists ${infoCounts.size} channels, @mcap/core ${jsCounts.size}`);
for (const [topic, n] of jsCounts) {
  check(infoCounts.get(topic) === n, `'${topic}': info ${infoCounts.get(topic)} == @mcap/core ${n}`);
  console.log(`${topic}: ${n} messages (info ${infoCounts.get(topic)}, stream ${streamCounts.get(topic)})`);
}
check(infoTotal === total, `info total ${infoTotal} == @mcap/core total ${total}`);

console.log(`${passed} passed, ${failed} failed`);
process.exit(failed === 0 ? 0 : 1);
