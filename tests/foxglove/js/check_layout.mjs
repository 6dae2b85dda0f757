// Checks deploy/foxglove/hexataar.layout.json against a session recording: the layout is a
// Foxglove layout (configById + a mosaic tree naming exactly those panels), the 3-D panel shows
// topics of the recording that carry foxglove.SceneUpdate / FrameTransforms and follows a frame
// the transforms define, and every plot / state path (topic{filter}.field[index]) parses, names
// a topic and fields of its schema, and selects values in the recording (so no panel of the
// layout is empty when it opens a session recording).
//   node check_layout.mjs LAYOUT.json SESSION.mcap
import { createRequire } from "node:module";
import { readFileSync } from "node:fs";
import { McapIndexedReader } from "@mcap/core";
import { loadDecompressHandlers } from "@mcap/support";

const require = createRequire(import.meta.url);
const protobuf = require("protobufjs");
const descriptor = require("protobufjs/ext/descriptor");
const [layoutPath, file] = process.argv.slice(2);
let passed = 0;
let failed = 0;
const check = (ok, what) => {
  if (ok) passed += 1;
  else {
    failed += 1;
    console.error(`FAIL: ${what}`);
  }
};
const layout = JSON.parse(readFileSync(layoutPath, "utf8"));
check(typeof layout.configById === "object" && layout.layout !== undefined, "configById and layout present");
const inTree = [];
const walk = (n) => {
  if (typeof n === "string") inTree.push(n);
  else {
    check(["row", "column"].includes(n.direction), `split direction '${n.direction}'`);
    check(n.splitPercentage > 0 && n.splitPercentage < 100, `split ${n.splitPercentage}`);
    walk(n.first);
    walk(n.second);
  }
};
walk(layout.layout);
const ids = Object.keys(layout.configById);
check(JSON.stringify([...inTree].sort()) === JSON.stringify([...ids].sort()),
      `panels in the tree ${inTree} == configById ${ids}`);
for (const id of ids) check(/^[A-Za-z0-9]+![A-Za-z0-9_]+$/.test(id), `panel id '${id}' is Type!name`);
const types = ids.map((i) => i.split("!")[0]);
for (const t of ["3D", "Plot", "StateTransitions"]) check(types.includes(t), `a ${t} panel`);
// The operator controls (Publish panels; the bridge with --operator-input): each publishes a
// JSON operator input on hexa_OperatorInput with the fields of its command (services/bridge/
// operator_input.hpp): start stop reset home stream once each, jogs along each axis both ways
// and about z, a pose goal, and the pivot (frames).
const fieldsOf = {
  start: ["command", "trajectory"], stop: ["command"], reset: ["command"], home: ["command"],
  stream: ["command"], jog: ["command", "frame", "velocity_m_s", "angular_velocity_rad_s"],
  goal: ["command", "position_m", "orientation_wxyz"],
  frames: ["command", "pivot_m", "tool_position_m", "tool_orientation_wxyz", "work_position_m", "work_orientation_wxyz"],
};
const commands = [];
const jogs = new Set();
for (const [id, config] of Object.entries(layout.configById)) {
  if (!id.startsWith("Publish!")) continue;
  check(config.topicName === "hexa_OperatorInput", `${id} publishes on hexa_OperatorInput`);
  const value = JSON.parse(config.value);
  const allowed = fieldsOf[value.command] ?? [];
  check(Object.keys(value).every((k) => allowed.includes(k)), `${id}: fields ${Object.keys(value)}`);
  if (value.command === "jog") {
    const twist = [...value.velocity_m_s, ...value.angular_velocity_rad_s];
    check(twist.length === 6 && twist.filter((v) => v !== 0).length === 1, `${id}: one axis`);
    jogs.add(twist.map((v) => Math.sign(v)).join(","));
  } else {
    commands.push(value.command);
  }
  if (value.command === "goal") {
    const q = value.orientation_wxyz;
    check(value.position_m.length === 3 && q.length === 4 &&
          Math.abs(Math.hypot(...q) - 1) < 1e-6, `${id}: a position and a unit quaternion`);
  }
  if (value.command === "frames") {
    check(value.pivot_m.length === 3 && Math.hypot(...value.pivot_m) <= 0.5,
          `${id}: a pivot within the supervisor's 0.5 m (${value.pivot_m})`);
  }
}
check(JSON.stringify(commands.sort()) === JSON.stringify(["frames", "goal", "home", "reset", "start", "stop", "stream"]),
      `operator controls for start stop reset home stream goal frames (${commands})`);
check(jogs.size === 8, `jogs along x, y, z both ways and about z both ways (${[...jogs]})`);

// The recording: schema per topic and every decoded message.
const bytes = new Uint8Array(readFileSync(file));
const reader = await McapIndexedReader.Initialize({
  readable: { size: async () => BigInt(bytes.length), read: async (o, s) => bytes.subarray(Number(o), Number(o + s)) },
  decompressHandlers: await loadDecompressHandlers(),
});
const topicType = new Map();
for (const [, ch] of reader.channelsById) {
  const s = reader.schemasById.get(ch.schemaId);
  topicType.set(ch.topic, { name: s.name, type: protobuf.Root.fromDescriptor(descriptor.FileDescriptorSet.decode(s.data)).lookupType(s.name) });
}
const messages = new Map();
for await (const m of reader.readMessages()) {
  const ch = reader.channelsById.get(m.channelId);
  const { type } = topicType.get(ch.topic);
  if (!messages.has(ch.topic)) messages.set(ch.topic, []);
  messages.get(ch.topic).push(type.toObject(type.decode(m.data), { longs: Number, enums: Number, defaults: true }));
}

// Message paths: topic, optional {field==number} filter, .field segments, optional [index].
// (The subset of Foxglove's message path syntax the layout uses; a topic name of letters,
// digits, _ / - needs no quotes there.)
function evaluate(pathText) {
  const m = pathText.match(/^([a-zA-Z0-9_/-]+)(\{([a-z_]+)==(\d+)\})?((\.[a-z_]+(\[\d+\])?)+)$/);
  if (!m) return { error: "does not parse" };
  const [, topic, , filterField, filterValue, fieldsText] = m;
  if (!topicType.has(topic)) return { error: `topic '${topic}' is not in the recording` };
  let type = topicType.get(topic).type;
  if (filterField && !type.fields[filterField]) return { error: `filter field '${filterField}' not in ${type.name}` };
  const segs = [...fieldsText.matchAll(/\.([a-z_]+)(\[(\d+)\])?/g)].map((x) => ({ name: x[1], index: x[3] }));
  for (const s of segs) {
    const f = type.fields[s.name];
    if (!f) return { error: `field '${s.name}' not in ${type.name}` };
    f.resolve();
    if (s.index !== undefined && !f.repeated) return { error: `'${s.name}' is not repeated` };
    if (f.resolvedType instanceof protobuf.Type) type = f.resolvedType;
  }
  let values = 0;
  for (const msg of messages.get(topic) ?? []) {
    if (filterField && msg[filterField] !== Number(filterValue)) continue;
    let v = msg;
    for (const s of segs) {
      v = v?.[s.name];
      if (s.index !== undefined) v = v?.[Number(s.index)];
    }
    if (typeof v === "number" && Number.isFinite(v)) values += 1;
  }
  return { values };
}

for (const [id, config] of Object.entries(layout.configById)) {
  if (id.startsWith("3D!")) {
    const topics = Object.entries(config.topics ?? {}).filter(([, v]) => v.visible).map(([t]) => t);
    check(topics.length >= 2, `${id}: shows ${topics}`);
    for (const t of topics) {
      check(topicType.has(t) && topicType.get(t).name.startsWith("foxglove."),
            `${id}: topic ${t} is in the recording with a foxglove schema (${topicType.get(t)?.name})`);
    }
    const frames = new Set();
    for (const tf of messages.get("hexa_FrameTransforms") ?? []) {
      for (const t of tf.transforms) {
        frames.add(t.parent_frame_id);
        frames.add(t.child_frame_id);
      }
    }
    check(frames.has(config.followTf), `${id}: follows frame '${config.followTf}' (frames: ${[...frames]})`);
    continue;
  }
  for (const p of config.paths ?? []) {
    const r = evaluate(p.value);
    check(r.error === undefined && r.values > 10,
          `${id}: '${p.value}' ${r.error ?? `selects ${r.values} values`}`);
    if (r.error === undefined) console.log(`${id}: ${p.value}: ${r.values} values`);
  }
}
const pathsOf = (prefix) => Object.entries(layout.configById).filter(([i]) => i.startsWith(prefix)).flatMap(([, c]) => c.paths.map((p) => p.value));
const all = pathsOf("Plot!").concat(pathsOf("StateTransitions!"));
for (let leg = 1; leg <= 6; ++leg) {
  check(all.includes(`hexa_LegSensors{leg_id==${leg}}.length_m`), `measured length of leg ${leg} plotted`);
  check(all.includes(`hexa_ValveCommand{leg_id==${leg}}.desired_length_m`), `desired length of leg ${leg} plotted`);
  check(all.includes(`hexa_ValveCommand{leg_id==${leg}}.valve_v`), `valve voltage of leg ${leg} plotted`);
}
for (let i = 0; i < 6; ++i) check(all.includes(`hexa_PoseReport.error_pose[${i}]`), `pose error axis ${i} plotted`);
check(all.includes("hexa_PoseReport.state"), "supervisor state shown");
console.log(`${passed} passed, ${failed} failed`);
process.exit(failed === 0 ? 0 : 1);
