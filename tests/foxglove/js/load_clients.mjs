// N Foxglove clients in one process (@foxglove/ws-protocol over `ws`), each subscribed to every
// channel of hexa_bridge and reading as fast as it can; a load for benchmarks
// (bench/bridge/run_rt_clients.py):
//   node load_clients.mjs ws://127.0.0.1:PORT N
// Prints "subscribed N" once every client has subscribed, and the messages received per client
// ("received MIN..MAX messages per client, TOTAL in all") when every client's connection has
// closed (the bridge ended with its session) or on SIGTERM / SIGINT, whichever comes first,
// and exits. (Once every connection has closed node has nothing left to wait for and would
// exit before a signal came: the counts were lost.)
import { createRequire } from "node:module";
import WebSocket from "ws";

const require = createRequire(import.meta.url);
const { FoxgloveClient } = require("@foxglove/ws-protocol");
const [url, countText] = process.argv.slice(2);
const n = Number(countText);
const clients = [];
let subscribed = 0;
let closed = 0;
for (let i = 0; i < n; i += 1) {
  const c = { received: 0, subscribed: false };
  c.client = new FoxgloveClient({ ws: new WebSocket(url, [FoxgloveClient.SUPPORTED_SUBPROTOCOL]) });
  c.client.on("advertise", (chs) => {
    if (c.subscribed) return;
    for (const ch of chs) c.client.subscribe(ch.id);
    c.subscribed = true;
    subscribed += 1;
    if (subscribed === n) console.log(`subscribed ${n}`);
  });
  c.client.on("message", () => (c.received += 1));
  c.client.on("close", () => {
    closed += 1;
    if (closed === n) done("every connection closed by the server");
  });
  c.client.on("error", () => {});
  clients.push(c);
}
let reported = false;
function done(why) {
  if (reported) return;
  reported = true;
  const got = clients.map((c) => c.received);
  for (const c of clients) c.client.close();
  // Written to a pipe, stdout is asynchronous: exit once the line is out.
  process.stdout.write(`received ${Math.min(...got)}..${Math.max(...got)} messages per client, ` +
                       `${got.reduce((a, b) => a + b, 0)} in all (${why})\n`, () => process.exit(0));
}
process.on("SIGTERM", () => done("stopped by SIGTERM"));
process.on("SIGINT", () => done("stopped by SIGINT"));
