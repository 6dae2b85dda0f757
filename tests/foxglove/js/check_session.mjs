// Reads a zstd-compressed session recording with the MCAP project's own libraries and checks
// the 3-D scene against Foxglove's published schemas. Nothing here was written by this project
// except this script: @mcap/core (reader), @mcap/support (zstd decompression), protobufjs, and
// @foxglove/schemas (Foxglove's schema definitions, from which their .proto files are generated).
//   node check_session.mjs FILE.mcap HEXA_RECORDER [--expect-compression zstd|none]
// 1. McapIndexedReader + McapStreamReader with @mcap/support's decompressors read every chunk
//    (CRCs validated); every chunk has the expected compression.
// 2. Every message of every channel decodes with protobufjs from the schema in the file.
// 3. Per-topic counts and the total equal `hexa_recorder info`'s.
// 4. The foxglove.* types in the file equal Foxglove's published ones field by field (name,
//    number, type, label), every scene message decodes with Foxglove's own definitions to the
//    same content, and has what docs/foxglove.md promises (frames, six legs, joints, outlines).
// Prints "N passed, M failed"; exits 1 on any failure.
import { createRequire } from "node:module";
import { execFileSync } from "node:child_process";
import { readFileSync } from "node:fs";
import { McapIndexedReader, McapStreamReader } from "@mcap/core";
import { loadDecompressHandlers } from "@mcap/support";

const require = createRequire(import.meta.url);
const protobuf = require("protobufjs");
const descriptor = require("protobufjs/ext/descriptor");
const fox = require("@foxglove/schemas/internal");

const args = process.argv.slice(2);
const [file, recorderBin] = args;
const expectIdx = args.indexOf("--expect-compression");
const expectCompression = expectIdx >= 0 ? args[expectIdx + 1] : "zstd";
if (!file || !recorderBin) {
  console.error("usage: node check_session.mjs FILE.mcap HEXA_RECORDER [--expect-compression zstd|none]");
  process.exit(2);
}
let passed = 0;
let failed = 0;
function check(ok, what) {
  if (ok) passed += 1;
  else {
    failed += 1;
    console.error(`FAIL: ${what}`);
  }
}

const decompressHandlers = await loadDecompressHandlers();
const bytes = new Uint8Array(readFileSync(file));
const readable = {
  size: async () => BigInt(bytes.length),
  read: async (offset, size) => bytes.subarray(Number(offset), Number(offset + size)),
};

// ---- 1 + 2 ---------------------------------------------------------------------------------
const reader = await McapIndexedReader.Initialize({ readable, decompressHandlers });
const wanted = expectCompression === "none" ? "" : expectCompression;
const kinds = new Set(reader.chunkIndexes.map((c) => c.compression));
check(reader.chunkIndexes.length > 0, "the file has chunks");
check(kinds.size === 1 && kinds.has(wanted),
      `every chunk index says compression '${wanted}' (saw ${[...kinds].map((k) => `'${k}'`)})`);
if (wanted !== "") {
  const stored = reader.chunkIndexes.reduce((a, c) => a + c.compressedSize, 0n);
  const raw = reader.chunkIndexes.reduce((a, c) => a + c.uncompressedSize, 0n);
  check(stored < raw, `compressed ${stored} < uncompressed ${raw} bytes`);
  console.log(`chunks: ${reader.chunkIndexes.length}, records ${raw} bytes stored as ${stored} (ratio ${(Number(raw) / Number(stored)).toFixed(2)})`);
}
const typesBySchema = new Map();
const rootsBySchema = new Map();
for (const [id, schema] of reader.schemasById) {
  check(schema.encoding === "protobuf", `schema ${id} encoding '${schema.encoding}'`);
  const root = protobuf.Root.fromDescriptor(descriptor.FileDescriptorSet.decode(schema.data));
  const type = root.lookupType(schema.name);
  typesBySchema.set(id, type);
  rootsBySchema.set(schema.name, root);
}
const counts = new Map();
for (const [, ch] of reader.channelsById) counts.set(ch.topic, 0);
let decodeFailures = 0;
let total = 0;
const sceneMessages = [];
const tfMessages = [];
for await (const msg of reader.readMessages({ validateCrcs: true })) {
  const ch = reader.channelsById.get(msg.channelId);
  const schema = reader.schemasById.get(ch.schemaId);
  let obj;
  try {
    const type = typesBySchema.get(ch.schemaId);
    obj = type.toObject(type.decode(msg.data), { longs: String, enums: String, defaults: true });
  } catch (e) {
    decodeFailures += 1;
    if (decodeFailures < 5) console.error(`decode failure on ${ch.topic}: ${e}`);
    continue;
  }
  if (schema.name === "foxglove.SceneUpdate") sceneMessages.push({ msg, obj });
  if (schema.name === "foxglove.FrameTransforms") tfMessages.push({ msg, obj });
  counts.set(ch.topic, counts.get(ch.topic) + 1);
  total += 1;
}
check(decodeFailures === 0, `${decodeFailures} messages failed to decode`);
check(BigInt(total) === reader.statistics.messageCount,
      `indexed read ${total} == statistics ${reader.statistics.messageCount}`);

const stream = new McapStreamReader({ validateCrcs: true, decompressHandlers });
stream.append(bytes);
const streamCounts = new Map();
const streamTopics = new Map();
let streamChunks = 0;
for (let rec; (rec = stream.nextRecord()); ) {
  if (rec.type === "Channel") streamTopics.set(rec.id, rec.topic);
  if (rec.type === "Message") {
    const t = streamTopics.get(rec.channelId);
    streamCounts.set(t, (streamCounts.get(t) ?? 0) + 1);
  }
}
check(stream.done(), "stream reader consumed the whole file");
for (const [topic, n] of counts) {
  check((streamCounts.get(topic) ?? 0) === n, `'${topic}': stream ${streamCounts.get(topic) ?? 0} == indexed ${n}`);
}

// ---- 3 -------------------------------------------------------------------------------------
const info = execFileSync(recorderBin, ["info", file], { encoding: "utf8", maxBuffer: 1 << 26 });
const infoCounts = new Map();
let infoTotal = -1;
for (const line of info.split("\n")) {
  const m = line.match(/^(\d+)\s+(\S+)\s+(\S+)\s+(\d+)\s/);
  if (m) infoCounts.set(m[2], Number(m[4]));
  const t = line.match(/^messages:\s+(\d+) in/);
  if (t) infoTotal = Number(t[1]);
}
check(infoCounts.size === counts.size, `info lists ${infoCounts.size} channels, @mcap/core ${counts.size}`);
for (const [topic, n] of counts) {
  check(infoCounts.get(topic) === n, `'${topic}': info ${infoCounts.get(topic)} == @mcap/core ${n}`);
  console.log(`${topic}: ${n} messages (info ${infoCounts.get(topic)})`);
}
check(infoTotal === total, `info total ${infoTotal} == @mcap/core total ${total}`);

// ---- 4: Foxglove's published schemas --------------------------------------------------------
const official = new protobuf.Root();
official.addJSON(protobuf.common.get("google/protobuf/timestamp.proto").nested);
official.addJSON(protobuf.common.get("google/protobuf/duration.proto").nested);
for (const schema of Object.values(fox.foxgloveMessageSchemas)) {
  const enums = Object.values(fox.foxgloveEnumSchemas).filter((e) => e.parentSchemaName === schema.name);
  protobuf.parse(fox.generateProto(schema, enums), official, { keepCase: true });
}
official.resolveAll();
let comparedTypes = 0;
for (const schemaName of ["foxglove.SceneUpdate", "foxglove.FrameTransforms"]) {
  const ours = rootsBySchema.get(schemaName);
  check(ours !== undefined, `the recording carries the schema ${schemaName}`);
  if (!ours) continue;
  // Every foxglove.* message type reachable from the top type, compared field by field.
  const seen = new Set();
  const visit = (name) => {
    if (seen.has(name) || !name.startsWith("foxglove.")) return;
    seen.add(name);
    const a = ours.lookupType(name);
    const b = official.lookupType(name);
    // Field number, name, resolved type (full name for messages and enums) and label.
    const describe = (f) => {
      f.resolve();
      const type = (f.resolvedType ? f.resolvedType.fullName : f.type).replace(/^\./, "");
      return `${f.id} ${f.name} ${type} ${f.repeated ? "repeated" : "singular"}`;
    };
    const fa = Object.values(a.fields).map(describe).sort();
    const fb = Object.values(b.fields).map(describe).sort();
    check(JSON.stringify(fa) === JSON.stringify(fb),
          `${name}: fields ${JSON.stringify(fa)} == Foxglove's ${JSON.stringify(fb)}`);
    comparedTypes += 1;
    for (const f of Object.values(a.fields)) {
      f.resolve();
      if (f.resolvedType instanceof protobuf.Type) visit(f.resolvedType.fullName.replace(/^\./, ""));
      if (f.resolvedType instanceof protobuf.Enum) {
        const ea = f.resolvedType.values;
        const eb = official.lookupEnum(f.resolvedType.fullName.replace(/^\./, "")).values;
        check(JSON.stringify(ea) === JSON.stringify(eb), `${f.resolvedType.fullName} values equal Foxglove's`);
      }
    }
  };
  visit(schemaName);
}
console.log(`compared ${comparedTypes} foxglove types with @foxglove/schemas`);
check(comparedTypes >= 17, `${comparedTypes} foxglove types compared (SceneUpdate and FrameTransforms reach 17+)`);

const offScene = official.lookupType("foxglove.SceneUpdate");
const offTf = official.lookupType("foxglove.FrameTransforms");
const toObj = (t, b) => t.toObject(t.decode(b), { longs: String, enums: String, defaults: true });
let sameContent = 0;
let sceneProblems = 0;
let posesSeen = 0;
let truthSeen = false;
const problem = (what) => {
  sceneProblems += 1;
  if (sceneProblems < 6) console.error(`scene: ${what}`);
};
for (const { msg, obj } of sceneMessages) {
  const viaOfficial = toObj(offScene, msg.data);
  if (JSON.stringify(viaOfficial) === JSON.stringify(obj)) sameContent += 1;
  const ids = new Set(viaOfficial.entities.map((e) => e.id));
  // Before the first ground truth arrives (a pose report can come first) the legs are drawn on
  // the measured platform; from then on the ground-truth platform is there in every frame.
  if (ids.has("platform")) truthSeen = true;
  else if (truthSeen) problem(`entity 'platform' gone at log time ${msg.logTime}`);
  for (const id of ["base", "status", "leg1", "leg2", "leg3", "leg4", "leg5", "leg6"]) {
    if (!ids.has(id)) problem(`entity '${id}' missing at log time ${msg.logTime}`);
  }
  // The measured and desired platforms appear with the first pose report and stay.
  const poses = ids.has("platform_measured") && ids.has("platform_desired");
  if (poses) posesSeen += 1;
  else if (posesSeen > 0) problem(`measured / desired platform gone at log time ${msg.logTime}`);
  for (const e of viaOfficial.entities) {
    if (e.id.startsWith("leg")) {
      if (e.cylinders.length !== 1 || e.frame_id !== "base") problem(`${e.id}: one cylinder in base`);
      const c = e.cylinders[0];
      if (!(c.size.z > 0.3 && c.size.z < 0.7)) problem(`${e.id}: length ${c.size.z} m`);
      const state = e.metadata.find((kv) => kv.key === "state");
      if (!state || !["ok", "hold", "fault", "standby active", "unknown"].includes(state.value))
        problem(`${e.id}: state ${JSON.stringify(state)}`);
    }
    if (e.id === "base" && (e.spheres.length !== 6 || e.lines.length !== 1 || e.lines[0].points.length !== 6))
      problem("base: 6 joints and a 6-point outline");
    if (e.id === "platform" && (e.frame_id !== "platform" || e.spheres.length !== 6 || e.lines[0].type !== "LINE_LOOP"))
      problem("platform: 6 joints, outline loop, frame platform");
  }
}
check(sceneMessages.length > 0, `${sceneMessages.length} scene messages`);
check(truthSeen, "the ground-truth platform is drawn");
check(posesSeen > 0.9 * sceneMessages.length,
      `${posesSeen} of ${sceneMessages.length} scene messages show the measured and desired platforms`);
check(sameContent === sceneMessages.length,
      `${sameContent} of ${sceneMessages.length} scene messages decode identically with Foxglove's definitions`);
check(sceneProblems === 0, `${sceneProblems} problems in the scene content`);
let tfSame = 0;
let tfProblems = 0;
let tfFull = 0;
for (const { msg, obj } of tfMessages) {
  const o = toObj(offTf, msg.data);
  if (JSON.stringify(o) === JSON.stringify(obj)) tfSame += 1;
  const children = o.transforms.map((t) => `${t.parent_frame_id}->${t.child_frame_id}`).sort().join(",");
  if (children === "base->platform,base->platform_desired,base->platform_measured") tfFull += 1;
  else if (!["base->platform", "base->platform_desired,base->platform_measured"].includes(children)) tfProblems += 1;
  for (const t of o.transforms) {
    const q = t.rotation;
    const n = Math.hypot(q.x, q.y, q.z, q.w);
    if (Math.abs(n - 1) > 1e-9) tfProblems += 1;
  }
}
check(tfMessages.length > 0 && tfSame === tfMessages.length,
      `${tfSame} of ${tfMessages.length} transform messages decode identically with Foxglove's definitions`);
check(tfProblems === 0, `${tfProblems} transform messages with other frames or a non-unit rotation`);
check(tfFull > 0.9 * tfMessages.length, `${tfFull} of ${tfMessages.length} transform messages carry all three frames`);

console.log(`${passed} passed, ${failed} failed`);
process.exit(failed === 0 ? 0 : 1);
