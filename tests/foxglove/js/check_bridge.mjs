// Live check of hexa_bridge with Foxglove's own WebSocket client library (@foxglove/ws-protocol
// over the `ws` package) while a session runs:
//   node check_bridge.mjs ws://127.0.0.1:PORT
// 1. connect, serverInfo, list the advertised channels; every schema is a protobuf
//    FileDescriptorSet that protobufjs loads;
// 2. subscribe to hexa_LegSensors and hexa_Scene, decode 1000 LegSensors messages and the scene
//    messages that arrive meanwhile with protobufjs; plausible values, ticks increasing per leg;
// 3. unsubscribe: nothing arrives on those subscriptions after 300 ms;
// 4. bad clients: garbage text, an unknown op, a binary frame each get a status error and a
//    close with code 1002 (protocol error); a handshake without the subprotocol is refused;
// 5. the bridge goes on: a new client subscribes again and receives LegSensors.
import { createRequire } from "node:module";
import WebSocket from "ws";

const require = createRequire(import.meta.url);
const { FoxgloveClient } = require("@foxglove/ws-protocol");
const protobuf = require("protobufjs");
const descriptor = require("protobufjs/ext/descriptor");
const url = process.argv[2];
let passed = 0;
let failed = 0;
function check(ok, what) {
  if (ok) passed += 1;
  else {
    failed += 1;
    console.error(`FAIL: ${what}`);
  }
}
const sleep = (ms) => new Promise((r) => setTimeout(r, ms));
async function until(pred, ms, what) {
  const t0 = Date.now();
  while (!pred()) {
    if (Date.now() - t0 > ms) throw new Error(`timeout after ${ms} ms: ${what}`);
    await sleep(20);
  }
}

function connect() {
  const c = { channels: new Map(), info: null, statuses: [], messages: [], closed: null };
  c.client = new FoxgloveClient({ ws: new WebSocket(url, [FoxgloveClient.SUPPORTED_SUBPROTOCOL]) });
  c.client.on("serverInfo", (i) => (c.info = i));
  c.client.on("advertise", (chs) => chs.forEach((ch) => c.channels.set(ch.topic, ch)));
  c.client.on("status", (s) => c.statuses.push(s));
  c.client.on("message", (m) => c.messages.push({ ...m, at: Date.now() }));
  c.client.on("close", (e) => (c.closed = e));
  return c;
}

function typeOf(ch) {
  const set = descriptor.FileDescriptorSet.decode(Buffer.from(ch.schema, "base64"));
  return protobuf.Root.fromDescriptor(set).lookupType(ch.schemaName);
}

// A raw WebSocket client (ws package) for the bad-input cases.
async function badClient(send, what) {
  const ws = new WebSocket(url, ["foxglove.websocket.v1"]);
  const statuses = [];
  let code = null;
  ws.on("message", (data, isBinary) => {
    if (isBinary) return;
    const m = JSON.parse(data.toString());
    if (m.op === "status") statuses.push(m);
  });
  ws.on("close", (c) => (code = c));
  await new Promise((resolve, reject) => {
    ws.on("open", resolve);
    ws.on("error", reject);
  });
  send(ws);
  await until(() => code !== null, 10000, `${what}: connection closed by the bridge`);
  check(statuses.some((s) => s.level === 2), `${what}: a status error (${JSON.stringify(statuses.map((s) => s.message))})`);
  check(code === 1002, `${what}: closed with 1002 protocol error (got ${code})`);
  console.log(`${what}: status '${statuses.map((s) => s.message).join(" | ")}', close ${code}`);
}

try {
  // ---- 1 -----------------------------------------------------------------------------------
  const a = connect();
  await until(() => a.info && a.channels.size > 0, 20000, "serverInfo and advertise");
  check(a.info.name === "hexa_bridge", `serverInfo name '${a.info.name}'`);
  console.log(`channels: ${[...a.channels.values()].map((c) => `${c.id}:${c.topic}(${c.schemaName})`).join(" ")}`);
  for (const t of ["hexa_LegSensors", "hexa_ValveCommand", "hexa_GroundTruth", "hexa_PoseReport",
                   "hexa_ImuSample", "hexa_LegSetpoint", "hexa_NodeStatus", "hexa_FaultEvent",
                   "hexa_OperatorCommand", "hexa_TrackerPose", "hexa_Scene", "hexa_FrameTransforms"]) {
    check(a.channels.has(t), `channel ${t} advertised`);
  }
  const types = new Map();
  for (const ch of a.channels.values()) {
    check(ch.encoding === "protobuf" && ch.schemaEncoding === "protobuf", `${ch.topic}: protobuf`);
    types.set(ch.id, typeOf(ch));
  }
  // ---- 2 -----------------------------------------------------------------------------------
  const sensors = a.channels.get("hexa_LegSensors");
  const scene = a.channels.get("hexa_Scene");
  const subSensors = a.client.subscribe(sensors.id);
  const subScene = a.client.subscribe(scene.id);
  const decoded = { sensors: [], scene: [] };
  let badDecode = 0;
  a.client.on("message", (m) => {
    const bytes = new Uint8Array(m.data.buffer, m.data.byteOffset, m.data.byteLength);
    try {
      if (m.subscriptionId === subSensors) decoded.sensors.push(types.get(sensors.id).toObject(types.get(sensors.id).decode(bytes), { longs: Number, defaults: true }));
      if (m.subscriptionId === subScene) decoded.scene.push(types.get(scene.id).toObject(types.get(scene.id).decode(bytes), { defaults: true }));
    } catch (e) {
      badDecode += 1;
    }
  });
  await until(() => decoded.sensors.length >= 1000 && decoded.scene.length >= 5, 60000,
              "1000 LegSensors and 5 scene messages");
  check(badDecode === 0, `${badDecode} messages failed to decode`);
  const first1000 = decoded.sensors.slice(0, 1000);
  const lastTick = new Map();
  let implausible = 0;
  let backwards = 0;
  for (const s of first1000) {
    if (!(s.leg_id >= 1 && s.leg_id <= 6 && s.length_m > 0.3 && s.length_m < 0.7 && s.cap_pressure_pa > 1e4)) implausible += 1;
    if (lastTick.has(s.leg_id) && s.header.tick <= lastTick.get(s.leg_id)) backwards += 1;
    lastTick.set(s.leg_id, s.header.tick);
  }
  check(implausible === 0, `${implausible} of 1000 LegSensors with implausible values`);
  check(backwards === 0, `${backwards} LegSensors whose tick did not increase for their leg`);
  check(lastTick.size === 6, `LegSensors of ${lastTick.size} legs`);
  const legsPerScene = decoded.scene.map((u) => u.entities.filter((e) => /^leg[1-6]$/.test(e.id)).length);
  check(legsPerScene.every((n) => n === 6), `every scene message has six legs (${legsPerScene.slice(0, 8)})`);
  console.log(`decoded ${decoded.sensors.length} LegSensors (legs ${[...lastTick.keys()]}), ${decoded.scene.length} scene messages`);
  // ---- 3 -----------------------------------------------------------------------------------
  a.client.unsubscribe(subSensors);
  a.client.unsubscribe(subScene);
  const tUnsub = Date.now();
  await sleep(1500);
  const late = a.messages.filter((m) => m.at > tUnsub + 300).length;
  check(late === 0, `${late} messages arrived more than 300 ms after unsubscribe`);
  // ---- 4 -----------------------------------------------------------------------------------
  await badClient((ws) => ws.send("\u0000\u0001garbage{{ not json"), "garbage text");
  await badClient((ws) => ws.send(JSON.stringify({ op: "getParameters", parameterNames: [] })), "unknown op");
  await badClient((ws) => ws.send(Buffer.from([1, 0, 0, 0, 0, 42])), "binary frame");
  await badClient((ws) => ws.send(JSON.stringify({ op: "subscribe", subscriptions: [{ id: -1, channelId: "x" }] })),
                  "malformed subscribe");
  let refused = false;
  const plain = new WebSocket(url);
  await new Promise((resolve) => {
    plain.on("unexpected-response", (_req, res) => { refused = res.statusCode === 400; resolve(); });
    plain.on("open", resolve);
    plain.on("error", resolve);
  });
  check(refused, "a handshake without the foxglove.websocket.v1 subprotocol is refused (HTTP 400)");
  // ---- 5 -----------------------------------------------------------------------------------
  const b = connect();
  await until(() => b.info && b.channels.size > 0, 10000, "second client: advertise");
  const subB = b.client.subscribe(b.channels.get("hexa_LegSensors").id);
  await until(() => b.messages.filter((m) => m.subscriptionId === subB).length >= 100, 20000,
              "second client: 100 LegSensors after the bad clients");
  check(true, "the bridge goes on after the bad clients");
  b.client.close();
  a.client.close();
} catch (e) {
  check(false, String(e));
}
console.log(`${passed} passed, ${failed} failed`);
process.exit(failed === 0 ? 0 : 1);
