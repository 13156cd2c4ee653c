#!/usr/bin/env node
// The PLC's handshake with an independent npm client (modbus-serial) against the test server.
// usage: NODE_PATH=<dir>/node_modules node handshake_client.cjs SERVER_EXE
// Exit 0 = pass, 77 = modbus-serial not installed (`ninja palletd_modbus_npm_deps`), else fail.
// Runs the server high-word-first and --low-word-first; decodes 32-bit values with Buffer in the
// order register 109 advertises and compares with fake_result() (tests/modbus/fake_result.hpp).
"use strict";
const { spawn } = require("child_process");
const readline = require("readline");

let ModbusRTU;
try {
  ModbusRTU = require("modbus-serial");
} catch (e) {
  console.error("modbus-serial not installed: " + e.message);
  process.exit(77);
}

const READY = 1, BUSY = 2, TRIGGER_ACK = 4, RESULT_READY = 8, ERROR = 16;

function fakeResult(recipe, requestId) {
  if (recipe === 99) return { status: 2, found: 0, boxes: [] };
  const n = Math.min(recipe, 40);
  const boxes = [];
  for (let i = 0; i < n; ++i) {
    boxes.push({
      x: (requestId % 100) * 0.01 - 0.5 + 0.1 * i, y: -0.3 - 0.0123 * i, z: 1.2345,
      yaw: -179.0 + 7.5 * i, format: i % 3, score: ((i * 37) % 1000) / 1000, pick: i + 1,
    });
  }
  return { status: n ? 0 : 1, found: n, boxes: boxes.slice(0, 32), layerZ: -1.5 + 0.0001 * requestId };
}

function check(cond, message) {
  if (!cond) throw new Error("FAIL: " + message);
}

function int32(regs, at, lowFirst) {
  const b = Buffer.alloc(4);
  b.writeUInt16BE(lowFirst ? regs[at + 1] : regs[at], 0);
  b.writeUInt16BE(lowFirst ? regs[at] : regs[at + 1], 2);
  return b.readInt32BE(0);
}
const int16 = (v) => (v > 0x7fff ? v - 0x10000 : v);
const sleep = (ms) => new Promise((r) => setTimeout(r, ms));

async function startServer(exe, lowFirst) {
  const args = ["--port", "0", "--delay-ms", "40"].concat(lowFirst ? ["--low-word-first"] : []);
  const proc = spawn(exe, args, { stdio: ["ignore", "pipe", "inherit"] });
  const rl = readline.createInterface({ input: proc.stdout });
  const line = await new Promise((resolve, reject) => {
    rl.once("line", resolve);
    proc.once("exit", (code) => reject(new Error("server exited " + code)));
  });
  const m = /^PORT (\d+)$/.exec(line);
  check(m, "server printed " + line);
  return { proc, port: Number(m[1]) };
}

async function run(exe, lowFirst) {
  const { proc, port } = await startServer(exe, lowFirst);
  const client = new ModbusRTU();
  try {
    await client.connectTCP("127.0.0.1", { port });
    client.setID(1);
    client.setTimeout(2000);
    const read = async (a, n) => (await client.readHoldingRegisters(a, n)).data;
    const status = async () => (await read(100, 1))[0];
    const wait = async (mask, want, what) => {
      const deadline = Date.now() + 3000;
      while (Date.now() < deadline) {
        if (((await status()) & mask) === want) return;
        await sleep(5);
      }
      throw new Error("timed out waiting for " + what);
    };
    const st = (await client.readInputRegisters(100, 18)).data;
    check(st[8] === 1, "interface version");
    const low = (st[9] & 1) === 1;
    check(low === lowFirst, "format flags word order");
    check(int32(st, 10, low) === 0x12345678, "test pattern");
    check(int32(st, 10, !low) !== 0x12345678, "word order matters");

    let lastId = (await read(200, 1))[0];
    for (const [n, recipe] of [5, 0, 99, 33].entries()) {
      const request = 2000 + 13 * n;
      await wait(READY | BUSY, READY, "Ready");
      await client.writeRegisters(0, [1, recipe, request]);
      await wait(TRIGGER_ACK, TRIGGER_ACK, "TriggerAck");
      await client.writeRegister(0, 0);
      await wait(RESULT_READY | BUSY, RESULT_READY, "ResultReady");
      const regs = (await read(200, 125)).concat(await read(325, 125), await read(450, 81));
      const want = fakeResult(recipe, request);
      check(regs[0] === regs[330], "result id copy");
      check(regs[0] === ((lastId + 1) & 0xffff), "result id increments");
      lastId = regs[0];
      check(regs[1] === request && regs[5] === recipe, "request id / recipe echo");
      check(regs[2] === want.status, "result status " + regs[2]);
      check(regs[3] === want.found && regs[4] === want.boxes.length, "box counts");
      check((((await status()) & ERROR) !== 0) === (recipe === 99), "Error bit");
      if (want.boxes.length) check(Math.abs(int32(regs, 7, low) * 1e-4 - want.layerZ) < 1e-4, "layer z");
      want.boxes.forEach((w, i) => {
        const s = 10 + 10 * i;
        const got = { x: int32(regs, s, low) * 1e-4, y: int32(regs, s + 2, low) * 1e-4,
                      z: int32(regs, s + 4, low) * 1e-4, yaw: int16(regs[s + 6]) * 0.01,
                      score: regs[s + 8] / 1000 };
        for (const [k, tol] of [["x", 1e-4], ["y", 1e-4], ["z", 1e-4], ["yaw", 0.01], ["score", 1e-3]]) {
          check(Math.abs(got[k] - w[k]) <= tol + 1e-9, `box ${i} ${k}: ${got[k]} vs ${w[k]}`);
        }
        check(regs[s + 7] === w.format && regs[s + 9] === w.pick, "format / pick");
      });
      check(regs.slice(10 + 10 * regs[4], 330).every((v) => v === 0), "unused slots zero");
      await client.writeRegister(0, 2);  // ResultAck
      await wait(RESULT_READY, 0, "ResultReady cleared");
      await client.writeRegister(0, 4);  // ClearError
      await client.writeRegister(0, 0);
    }
    console.log(`modbus-serial handshake ok (${lowFirst ? "low" : "high"} word first)`);
  } finally {
    client.close(() => {});
    const exited = new Promise((resolve) => {
      if (proc.exitCode !== null || proc.signalCode !== null) resolve();
      else proc.once("exit", resolve);
    });
    proc.kill("SIGTERM");
    await exited;  // reap the server before this process ends
    check(proc.exitCode === 0, "server exit status " + proc.exitCode);
  }
}

(async () => {
  const exe = process.argv[2];
  if (!exe) {
    console.error("usage: handshake_client.cjs SERVER_EXE");
    process.exit(2);
  }
  try {
    await run(exe, false);
    await run(exe, true);
    process.exit(0);
  } catch (e) {
    console.error(e.message);
    process.exit(1);
  }
})();
