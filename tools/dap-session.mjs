// One debugging session against shoal's DAP server, driven by Microsoft's own adapter test client
// (@vscode/debugadapter-testsupport), the way an editor drives it: initialize, attach or launch,
// a conditional breakpoint and a logpoint in forage.lua, configurationDone, stopped, stack,
// scopes, locals, evaluate, next (its response, then the stopped event it causes), clear the
// breakpoints, continue to `terminated`, disconnect.
//
//   node tools/dap-session.mjs PORT attach|launch /path/to/scripts/behaviors/forage.lua
//
// Prints one JSON line with what it saw and exits 0, or prints the failure and exits 1. In
// server mode the client has no timeouts of its own, so a hang ends here after 90 s.
import { writeSync } from "node:fs";
import testsupport from "@vscode/debugadapter-testsupport";

const { DebugClient } = testsupport;
const [port, mode, forage] = process.argv.slice(2);
if (!port || !["attach", "launch"].includes(mode) || !forage) {
  console.error("usage: node dap-session.mjs PORT attach|launch FORAGE_LUA");
  process.exit(2);
}

const seen = { mode, socketErrors: [], steps: [] };
const fail = (why) => {
  // Synchronous: process.exit would cut an asynchronous write to a pipe short.
  writeSync(1, JSON.stringify({ ...seen, ok: false, why: String(why) }) + "\n");
  process.exit(1);
};
setTimeout(() => fail("timed out after 90 s (a response or event never came)"), 90_000).unref();

const check = (cond, why) => {
  if (!cond) throw new Error(why);
};

async function session() {
  const dc = new DebugClient("node", "unused", "shoal");
  // Every output event, kept for the logpoint check.
  const output = [];
  dc.on("output", (e) => output.push(e.body.output));
  // What crossed the wire, in order, to check the protocol's ordering afterwards.
  const wire = [];
  const dispatch = dc.dispatch.bind(dc);
  dc.dispatch = (body) => {
    const m = JSON.parse(body);
    wire.push(m.type === "event" ? `event:${m.event}` : `response:${m.command}`);
    dispatch(body);
  };
  const doSend = dc.doSend.bind(dc);
  dc.doSend = (command, args, clb) => {
    wire.push(`request:${command}`);
    doSend(command, args, clb);
  };
  seen.wire = wire;
  await dc.start(Number(port));
  seen.stage = "connected";
  // A reset connection shows as an error on the client's socket.
  dc._socket.on("error", (e) => seen.socketErrors.push(e.code || String(e)));

  // The event comes right behind the response, often in the same read: wait for it first.
  const initialized = dc.waitForEvent("initialized");
  const init = await dc.initializeRequest({
    adapterID: "shoal",
    clientID: "debugadapter-testsupport",
    linesStartAt1: true,
    columnsStartAt1: true,
    pathFormat: "path",
  });
  check(init.body.supportsConditionalBreakpoints, "no conditional breakpoints");
  check(init.body.supportsLogPoints, "no logpoints");
  await initialized;
  seen.stage = "initialized";
  if (mode === "attach") {
    await dc.attachRequest({});
  } else {
    await dc.launchRequest({});
  }
  // forage.lua:19 is intend's first line; a condition that holds (fish ids start at 0);
  // line 20 a logpoint with an expression of the line's locals.
  const set = await dc.setBreakpointsRequest({
    source: { path: forage },
    breakpoints: [
      { line: 19, condition: "fish.id >= 0" },
      { line: 20, logMessage: "dt is {dt}" },
    ],
  });
  check(set.body.breakpoints.every((b) => b.verified), `unverified: ${JSON.stringify(set.body)}`);
  const stoppedAtFirst = dc.waitForEvent("stopped");
  await dc.configurationDoneRequest();
  seen.stage = "configured";
  const stopped = await stoppedAtFirst;
  seen.stage = "stopped";
  check(stopped.body.reason === "breakpoint", `stopped for ${stopped.body.reason}`);

  const threads = await dc.threadsRequest();
  const threadId = threads.body.threads[0].id;
  const top = async () => (await dc.stackTraceRequest({ threadId })).body.stackFrames[0];
  const frame = await top();
  seen.stoppedAt = `${frame.source.name}:${frame.line}`;
  const scopes = await dc.scopesRequest({ frameId: frame.id });
  const locals = await dc.variablesRequest({
    variablesReference: scopes.body.scopes[0].variablesReference,
  });
  seen.locals = locals.body.variables.map((v) => v.name);
  const evaluated = await dc.evaluateRequest({ expression: "fish.id >= 0", frameId: frame.id, context: "repl" });
  seen.evaluated = evaluated.body.result;

  // The waiter is set before the request (as the client's own helpers do): the event may
  // arrive in the same read as the response. The order itself is checked on `wire` below.
  for (let k = 0; k < 2; k++) {
    const stoppedAgain = dc.waitForEvent("stopped");
    await dc.nextRequest({ threadId });
    const e = await stoppedAgain;
    const f = await top();
    seen.steps.push(`${e.body.reason}@${f.source.name}:${f.line}`);
  }

  await dc.setBreakpointsRequest({ source: { path: forage }, breakpoints: [] });
  const terminated = dc.waitForEvent("terminated");
  await dc.continueRequest({ threadId });
  await terminated;
  seen.logpoint = output.find((o) => o.includes("forage.lua:20: dt is ")) ?? null;
  seen.passed = output.some((o) => o.includes("PASS"));
  await dc.disconnectRequest({});
  // Give a reset (ECONNRESET) time to arrive before looking.
  await new Promise((resolve) => {
    dc._socket.once("close", resolve);
    setTimeout(resolve, 3000).unref();
  });
  dc.stopAdapter();
  // The protocol's order: a request's response before any event it causes. Between sending
  // configurationDone, next or continue and its response, no stopped or terminated may come.
  let open = null;
  for (const m of wire) {
    const [kind, name] = m.split(":");
    if (kind === "request" && ["configurationDone", "next", "continue"].includes(name)) open = name;
    if (kind === "response" && name === open) open = null;
    check(
      !(open && kind === "event" && ["stopped", "terminated"].includes(name)),
      `${m} arrived before the response to ${open}: ${wire.join(" ")}`,
    );
  }
}

session().then(
  () => {
    writeSync(1, JSON.stringify({ ...seen, ok: true }) + "\n");
    process.exit(0);
  },
  (e) => fail(e && e.stack ? e.stack.split("\n")[0] : e),
);
