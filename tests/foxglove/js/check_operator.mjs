// Foxglove as the operator console, with Foxglove's own client library (@foxglove/ws-protocol
// over `ws`), against `hexa_session --wait-for-operator --bridge --bridge-operator-input`:
//   node check_operator.mjs ws://127.0.0.1:PORT
// 1. serverInfo advertises clientPublish (json); the client watches hexa_PoseReport.state;
// 2. bad inputs are refused, each with a status error naming why, and the connection stays:
//    a channel on another topic, another encoding, a message on a channel never advertised,
//    not JSON, NaN, absent command, unknown command, unknown field, a CSV path as trajectory,
//    trajectory on stop; meanwhile the supervisor stays IDLE;
// 3. 1000 messages at once (stop, which changes nothing while IDLE): at most the
//    burst (10) pass, the rest is refused for rate with a status;
// 4. jog (+x, work frame, 20 Hz until the platform moved 10 mm): the supervisor JOGGING, the
//    desired pose moving along +x, back to IDLE after the client lets go; a tool-frame jog likewise; bad jogs and
//    goals refused (absent field, non-unit quaternion, absurd); a goal 2 cm / 1 cm away:
//    GOAL, then IDLE on it; a goal outside the soft limits: refused by the supervisor (IDLE);
// 4b. the pivot: frames without a pivot, a NaN one, one 10 m away, a non-unit tool quaternion
//    refused by the bridge; one 0.8 m away refused by the supervisor (its answer, in its
//    NodeStatus, reaches the client); one 0.206 m away taken; a roll of 0.2 rad about it: the
//    setpoint's pivot point stays put while its origin moves (ground truth: operator_truth.py);
// 5. start (combined): the supervisor leaves IDLE (BLENDING, then TRACKING); an info status
//    says it was forwarded;
// 6. stop: the supervisor goes to STOPPING and then IDLE.
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
  else failed += 1;
  console.log(`${ok ? "ok" : "FAIL"}: ${what}`);
}
const sleep = (ms) => new Promise((r) => setTimeout(r, ms));
async function until(pred, ms, what) {
  const t0 = Date.now();
  while (!pred()) {
    if (Date.now() - t0 > ms) throw new Error(`timeout after ${ms} ms: ${what}`);
    await sleep(20);
  }
}
const STATES = ["IDLE", "BLENDING", "TRACKING", "STOPPING", "HOLD", "JOGGING", "GOAL"];
const enc = new TextEncoder();

const c = { info: null, channels: new Map(), statuses: [], states: [], closed: false };
const client = new FoxgloveClient({ ws: new WebSocket(url, [FoxgloveClient.SUPPORTED_SUBPROTOCOL]) });
client.on("serverInfo", (i) => (c.info = i));
client.on("advertise", (chs) => chs.forEach((ch) => c.channels.set(ch.topic, ch)));
client.on("status", (s) => c.statuses.push(s));
client.on("close", () => (c.closed = true));
let poseType = null;
let poseSub = null;
let statusType = null;
let statusSub = null;
c.answers = [];  // the supervisor's NodeStatus details that answer a command
client.on("message", (m) => {
  if (m.subscriptionId === statusSub) {
    const st = statusType.decode(new Uint8Array(m.data.buffer, m.data.byteOffset, m.data.byteLength));
    const who = st.nodeName ?? st.node_name;
    if (who === "supervisor" && /^command #\d+ /.test(st.detail) && c.answers[c.answers.length - 1] !== st.detail)
      c.answers.push(st.detail);
    return;
  }
  if (m.subscriptionId !== poseSub) return;
  const report = poseType.decode(new Uint8Array(m.data.buffer, m.data.byteOffset, m.data.byteLength));
  const state = STATES[report.state ?? 0];
  c.desired = report.desiredPose ?? report.desired_pose;
  if (c.states[c.states.length - 1] !== state) {
    c.states.push(state);
    console.log(`supervisor state: ${state}`);
  }
});
const state = () => c.states[c.states.length - 1];

// Sends one message and waits for the status that answers it.
async function answer(send, what) {
  const n = c.statuses.length;
  send();
  await until(() => c.statuses.length > n, 10000, `${what}: a status`);
  return c.statuses[n];
}
async function refused(send, what, words) {
  const s = await answer(send, what);
  check(s.level === 2 && s.message.includes(words),
        `${what}: refused with a status error naming it ('${s.message}')`);
}

try {
  await until(() => c.info && c.channels.has("hexa_PoseReport"), 30000, "serverInfo and advertise");
  check(c.info.capabilities.includes("clientPublish"), `capabilities ${JSON.stringify(c.info.capabilities)}`);
  check(JSON.stringify(c.info.supportedEncodings) === '["json"]', `encodings ${JSON.stringify(c.info.supportedEncodings)}`);
  const pose = c.channels.get("hexa_PoseReport");
  poseType = protobuf.Root.fromDescriptor(
    descriptor.FileDescriptorSet.decode(Buffer.from(pose.schema, "base64"))).lookupType(pose.schemaName);
  poseSub = client.subscribe(pose.id);
  const nodeStatus = c.channels.get("hexa_NodeStatus");
  statusType = protobuf.Root.fromDescriptor(
    descriptor.FileDescriptorSet.decode(Buffer.from(nodeStatus.schema, "base64"))).lookupType(nodeStatus.schemaName);
  statusSub = client.subscribe(nodeStatus.id);
  await until(() => state() === "IDLE", 60000, "the supervisor reports IDLE (waiting for the operator)");

  // ---- 2: bad inputs -----------------------------------------------------------------------
  await refused(() => client.advertise({ topic: "hexa_ValveCommand", encoding: "json", schemaName: "x" }),
                "a channel on hexa_ValveCommand", "not accepted");
  await refused(() => client.advertise({ topic: "hexa_OperatorInput", encoding: "protobuf", schemaName: "x" }),
                "an operator channel encoded protobuf", "encoding");
  await refused(() => client.sendMessage(4242, enc.encode('{"command":"start"}')),
                "a message on a channel never advertised", "not advertised");
  const op = client.advertise({ topic: "hexa_OperatorInput", encoding: "json", schemaName: "hexa.OperatorInput" });
  const send = (text) => () => client.sendMessage(op, enc.encode(text));
  await refused(send("start please"), "text that is not JSON", "not valid JSON");
  await refused(send('{"command": NaN}'), "NaN", "not valid JSON");
  await refused(send('{"trajectory": "combined"}'), "no command", "'command' is absent");
  await refused(send('{"command": 3}'), "a command that is a number", "must be a string");
  await refused(send('{"command": "jump"}'), "an unknown command", "unknown command 'jump'");
  await refused(send('{"command": "start", "speed": 2}'), "an unknown field", "unknown field 'speed'");
  await refused(send('{"command": "start", "trajectory": "/etc/passwd"}'), "a CSV path", "is not one of");
  await refused(send('{"command": "stop", "trajectory": "x"}'), "a trajectory on stop", "for start only");
  check(!c.closed, "the connection stays open after the refused inputs");
  await sleep(500);
  check(state() === "IDLE", `the supervisor is still IDLE (${c.states.join(" -> ")})`);

  // ---- 3: 1000 messages at once ------------------------------------------------------------
  const before = c.statuses.length;
  for (let i = 0; i < 1000; i += 1) client.sendMessage(op, enc.encode('{"command":"stop"}'));
  await until(() => c.statuses.slice(before).some((s) => s.message.includes("rate limit")), 10000,
              "a status about the rate limit");
  await sleep(500);
  await sleep(1500);  // the refusals are summed up once a second; the bucket refills
  const burst = c.statuses.slice(before);
  const forwarded = burst.filter((s) => s.level === 0 && s.message.includes("forwarded")).length;
  const rate = burst.filter((s) => s.message.includes("rate limit"));
  const refusedCount = rate.reduce((n, s) => n + Number(/^(\d+) operator input/.exec(s.message)?.[1] ?? 0), 0);
  console.log(`1000 stop messages at once: ${forwarded} forwarded; ${rate.map((s) => `'${s.message}'`).join(", ")}`);
  check(forwarded >= 1 && forwarded <= 11, `at most the burst forwarded (${forwarded})`);
  check(rate.every((s) => s.level === 2), "the rest refused for rate with status errors");
  check(forwarded + refusedCount === 1000, `every message forwarded or counted as refused (${forwarded} + ${refusedCount})`);

  // ---- 4: jog and goal ---------------------------------------------------------------------
  // Jog messages every 50 ms until `done()` (or 60 s): the session runs in lockstep, whose
  // simulated time may pass slower or faster than the wall clock, so the jog is held until the
  // platform has moved rather than for a wall-clock time; then let go.
  const jogUntil = async (done, text, what) => {
    const t0 = Date.now();
    while (!done() && Date.now() - t0 < 60000) {
      client.sendMessage(op, enc.encode(text));
      await sleep(50);
    }
    check(done(), what);
  };
  const x0 = c.desired[0];
  await jogUntil(() => c.states.includes("JOGGING") && c.desired[0] - x0 > 0.01,
                 '{"command":"jog","velocity_m_s":[0.03,0,0],"angular_velocity_rad_s":[0,0,0]}',
                 "jog +x: the supervisor JOGGING and the desired pose 10 mm along +x");
  await until(() => state() === "IDLE", 60000, "the supervisor IDLE after the jog was let go");
  const dx = c.desired[0] - x0;
  console.log(`jog +x 3 cm/s: IDLE again after the client let go; desired x moved ${(dx * 1e3).toFixed(2)} mm, ` +
              `y ${((c.desired[1]) * 1e3).toFixed(2)} mm`);
  check(dx > 0.01 && dx < 0.05, `the jog moved the platform along +x and stopped (${(dx * 1e3).toFixed(2)} mm)`);
  const y0 = c.desired[1];
  const jogging = c.states.length;
  await jogUntil(() => c.states.slice(jogging).includes("JOGGING") && c.desired[1] - y0 > 0.01,
                 '{"command":"jog","frame":"tool","velocity_m_s":[0,0.03,0],"angular_velocity_rad_s":[0,0,0]}',
                 "tool-frame jog +y: JOGGING and 10 mm along +y");
  await until(() => state() === "IDLE", 60000, "IDLE after the tool-frame jog");
  await refused(send('{"command":"jog","velocity_m_s":[0,0,0]}'), "a jog without its angular velocity", "'angular_velocity_rad_s' is absent");
  await refused(send('{"command":"jog","velocity_m_s":[0,1e400,0],"angular_velocity_rad_s":[0,0,0]}'), "a jog of 1e400 m/s", "refused");
  await refused(send('{"command":"goal","position_m":[0,0,0.45]}'), "a goal without its orientation", "'orientation_wxyz' is absent");
  await refused(send('{"command":"goal","position_m":[0,0,0.45],"orientation_wxyz":[1,0,0,0.2]}'),
                "a goal with a non-unit quaternion", "not a unit quaternion");
  await refused(send('{"command":"goal","position_m":[10,0,0.45],"orientation_wxyz":[1,0,0,0]}'),
                "a goal 10 m away", "absurd");
  const goal = [c.desired[0] - 0.02, c.desired[1] + 0.01, c.desired[2]];
  const g = await answer(send(`{"command":"goal","position_m":[${goal.join(",")}],"orientation_wxyz":[1,0,0,0]}`), "goal");
  check(g.level === 0 && g.message.includes("goal forwarded"), `goal: '${g.message}'`);
  await until(() => c.states[c.states.length - 1] === "GOAL" || c.states.slice(-2).includes("GOAL"), 30000, "GOAL");
  await until(() => state() === "IDLE", 30000, "IDLE on the goal");
  const miss = Math.hypot(c.desired[0] - goal[0], c.desired[1] - goal[1], c.desired[2] - goal[2]);
  check(miss < 1e-6, `the desired pose ended on the goal (${miss.toExponential(2)} m)`);
  const outside = [goal[0] + 0.3, goal[1], goal[2]];
  const o = await answer(send(`{"command":"goal","position_m":[${outside.join(",")}],"orientation_wxyz":[1,0,0,0]}`), "a goal outside the soft limits");
  check(o.level === 0, `a goal outside the limits passes the bridge's checks ('${o.message}')`);
  await sleep(1000);
  check(state() === "IDLE", `the supervisor refused the goal outside the limits and stays IDLE (${c.states.slice(-3).join(" -> ")})`);

  // ---- 4b: the pivot -----------------------------------------------------------------------
  await sleep(1100);  // the command bucket full again (10)
  await refused(send('{"command":"frames"}'), "frames without the pivot", "field 'pivot_m' is absent");
  await refused(send('{"command":"frames","pivot_m":[0,NaN,0]}'), "a NaN pivot", "not valid JSON");
  await refused(send('{"command":"frames","pivot_m":[10,0,0]}'), "a pivot 10 m away",
                "pivot_m (10, 0, 0) is 10 m from the platform origin: absurd (limit 2 m)");
  await refused(send('{"command":"frames","pivot_m":[0,0,0.2],"tool_orientation_wxyz":[1,0,0,0.1]}'),
                "a tool frame with a non-unit quaternion", "tool_orientation_wxyz (1 0 0 0.1) is not a unit quaternion");
  // The supervisor's answer to a frames command, in its NodeStatus.
  const framesAnswer = async (pivot, what) => {
    const n = c.answers.length;
    const a = await answer(send(`{"command":"frames","pivot_m":[${pivot.join(",")}]}`), what);
    check(a.level === 0 && a.message.includes("frames forwarded"), `${what}: '${a.message}'`);
    await until(() => c.answers.slice(n).some((d) => / frames: /.test(d)), 30000, `${what}: the supervisor's answer`);
    return c.answers.slice(n).find((d) => / frames: /.test(d));
  };
  const far = await framesAnswer([0, 0, 0.8], "a pivot 0.8 m away (past the bridge's 2 m, past the supervisor's 0.5 m)");
  check(far.includes("frames: refused: frames refused: frames.p_PC_P_m: pivot point (from the platform origin) is too far away (value 0.8 m, limit <= 0.5 m)"),
        `the supervisor refused the pivot 0.8 m away and the client sees why ('${far}')`);
  const PIVOT = [0, 0.05, 0.2];
  const taken = await framesAnswer(PIVOT, "a pivot 0.2 m above the platform, 0.05 m aside");
  check(taken.includes("frames: accepted"), `the supervisor took the pivot ('${taken}')`);
  check(state() === "IDLE", "a frames command does not move the platform (IDLE)");
  // Roll about the new pivot (-0.15 rad/s, work frame) until the setpoint turned 0.2 rad, let go.
  // R = Rz(yaw) Ry(pitch) Rx(roll) (core/pose.hpp); the pivot in B is p + R p_PC_P.
  const pivotOf = (q) => {
    const [cr, sr, cp, sp, cy, sy] = [Math.cos(q[3]), Math.sin(q[3]), Math.cos(q[4]), Math.sin(q[4]), Math.cos(q[5]), Math.sin(q[5])];
    const R = [[cy * cp, cy * sp * sr - sy * cr, cy * sp * cr + sy * sr],
               [sy * cp, sy * sp * sr + cy * cr, sy * sp * cr - cy * sr],
               [-sp, cp * sr, cp * cr]];
    return [0, 1, 2].map((i) => q[i] + R[i][0] * PIVOT[0] + R[i][1] * PIVOT[1] + R[i][2] * PIVOT[2]);
  };
  const q0 = [...c.desired];
  const c0 = pivotOf(q0);
  let pivotMoved = 0;
  const rolling = c.states.length;
  const t0 = Date.now();
  while (!(c.states.slice(rolling).includes("JOGGING") && c.desired[3] - q0[3] < -0.2) && Date.now() - t0 < 60000) {
    client.sendMessage(op, enc.encode('{"command":"jog","velocity_m_s":[0,0,0],"angular_velocity_rad_s":[-0.15,0,0]}'));
    pivotMoved = Math.max(pivotMoved, Math.hypot(...pivotOf(c.desired).map((v, i) => v - c0[i])));
    await sleep(50);
  }
  await until(() => state() === "IDLE", 60000, "IDLE after the roll was let go");
  const q1 = [...c.desired];
  pivotMoved = Math.max(pivotMoved, Math.hypot(...pivotOf(q1).map((v, i) => v - c0[i])));
  const originMoved = Math.hypot(q1[0] - q0[0], q1[1] - q0[1], q1[2] - q0[2]);
  console.log(`roll about the pivot (${PIVOT.join(", ")}) m: setpoint roll ${(q1[3] - q0[3]).toFixed(4)} rad; ` +
              `the setpoint's pivot point moved at most ${pivotMoved.toExponential(2)} m, its origin ${(originMoved * 1e3).toFixed(2)} mm`);
  check(q1[3] - q0[3] < -0.2, `the setpoint rolled more than 0.2 rad (${(q1[3] - q0[3]).toFixed(4)} rad)`);
  check(pivotMoved < 1e-6, `the setpoint's pivot point stayed put (${pivotMoved.toExponential(2)} m)`);
  check(originMoved > 0.5 * Math.hypot(...PIVOT) * 0.2, `the platform origin moved (${(originMoved * 1e3).toFixed(2)} mm)`);

  // ---- 5: start ----------------------------------------------------------------------------
  const s = await answer(send('{"command":"start","trajectory":"combined"}'), "start");
  check(s.level === 0 && s.message.includes("start (combined) forwarded"), `start: '${s.message}'`);
  await until(() => state() === "TRACKING", 60000, "the supervisor tracking after start");
  check(c.states.includes("BLENDING") || c.states.includes("TRACKING"), `after start: ${c.states.join(" -> ")}`);

  // ---- 6: stop -----------------------------------------------------------------------------
  const t = await answer(send('{"command":"stop"}'), "stop");
  check(t.level === 0 && t.message.includes("stop forwarded"), `stop: '${t.message}'`);
  await until(() => c.states.slice(c.states.lastIndexOf("TRACKING")).includes("STOPPING"), 30000,
              "the supervisor stopping after stop");
  check(true, `after stop: ${c.states.join(" -> ")}`);
  await until(() => state() === "IDLE" || c.closed, 60000, "the supervisor back to IDLE");
  check(state() === "IDLE", `the supervisor back to IDLE (${c.states.join(" -> ")})`);
} catch (e) {
  failed += 1;
  console.log(`FAIL: ${e.message}`);
}
client.close();
console.log(`${passed} passed, ${failed} failed`);
process.exit(failed === 0 ? 0 : 1);
