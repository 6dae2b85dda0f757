// Extracts scene frames from a recording for the rendered check (render_scene.py): for N frames
// spread over the recording, the leg cylinders, the base joints (entity "base"), the platform
// joints (entity "platform", in frame "platform"), the base->platform transform of the same
// instant, and the GroundTruth message of the tick the legs were drawn at.
//   node extract_frames.mjs FILE.mcap OUT.json [N]
import { createRequire } from "node:module";
import { readFileSync, writeFileSync } from "node:fs";
import { McapIndexedReader } from "@mcap/core";
import { loadDecompressHandlers } from "@mcap/support";

const require = createRequire(import.meta.url);
const protobuf = require("protobufjs");
const descriptor = require("protobufjs/ext/descriptor");
const [file, out, nArg] = process.argv.slice(2);
const wantFrames = Number(nArg ?? 5);
const bytes = new Uint8Array(readFileSync(file));
const reader = await McapIndexedReader.Initialize({
  readable: { size: async () => BigInt(bytes.length), read: async (o, s) => bytes.subarray(Number(o), Number(o + s)) },
  decompressHandlers: await loadDecompressHandlers(),
});
const types = new Map();
for (const [id, s] of reader.schemasById) {
  types.set(id, protobuf.Root.fromDescriptor(descriptor.FileDescriptorSet.decode(s.data)).lookupType(s.name));
}
const opts = { longs: String, enums: String, defaults: true };
const scenes = [];
const tfByLog = new Map();
const truthByTick = new Map();
for await (const m of reader.readMessages()) {
  const ch = reader.channelsById.get(m.channelId);
  const t = types.get(ch.schemaId);
  if (ch.topic === "hexa_Scene") scenes.push({ log: m.logTime, obj: t.toObject(t.decode(m.data), opts) });
  else if (ch.topic === "hexa_FrameTransforms") tfByLog.set(m.logTime, t.toObject(t.decode(m.data), opts));
  else if (ch.topic === "hexa_GroundTruth") {
    const g = t.toObject(t.decode(m.data), opts);
    truthByTick.set(String(g.header.tick), g);
  }
}
const frames = [];
for (let k = 0; k < wantFrames && scenes.length > 0; ++k) {
  const s = scenes[Math.floor(((k + 0.5) / wantFrames) * scenes.length)];
  const ent = (id) => s.obj.entities.find((e) => e.id === id);
  const legs = [];
  let tick = null;
  for (let i = 1; i <= 6; ++i) {
    const e = ent(`leg${i}`);
    const c = e.cylinders[0];
    tick = e.metadata.find((kv) => kv.key === "tick").value;
    legs.push({ center: c.pose.position, q: c.pose.orientation, height: c.size.z,
                state: e.metadata.find((kv) => kv.key === "state").value });
  }
  const tf = tfByLog.get(s.log).transforms.find((t) => t.child_frame_id === "platform");
  const truth = truthByTick.get(tick);
  frames.push({
    log_time_ns: String(s.log), tick,
    legs,
    base_joints: ent("base").spheres.map((x) => x.pose.position),
    platform_joints_P: ent("platform").spheres.map((x) => x.pose.position),
    platform_tf: { t: tf.translation, q: tf.rotation },
    truth: truth ? { leg_length_m: truth.leg_length_m, position_m: truth.position_m,
                     orientation_wxyz: truth.orientation_wxyz } : null,
    joints_note: (ent("platform").metadata.find((kv) => kv.key === "joints") || {}).value,
  });
}
writeFileSync(out, JSON.stringify({ file, scene_messages: scenes.length, frames }, null, 1));
console.log(`${frames.length} frames of ${scenes.length} written to ${out}`);
