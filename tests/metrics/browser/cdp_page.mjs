// Drives headless Chromium over the DevTools protocol for the dashboard
// tests: opens URL, waits (polling, with a deadline) until a JavaScript
// condition holds, saves a screenshot, and prints one JSON line:
//   {"ok": bool, "value": <result of --eval>, "console_errors": [...], "error": "..."}
// Console errors, uncaught exceptions and failed loads are collected from the
// page's start.
// Usage: node --experimental-websocket cdp_page.mjs --chromium PATH --url URL
//          --until JS_EXPR [--eval JS_EXPR] [--screenshot FILE] [--timeout-ms N]
//          [--width W --height H]
//          [--first JS_EXPR --first-screenshot FILE --then-delete PATH]
// With --first: wait for it, screenshot, delete PATH (e.g. a worker's pause
// file, so the farm moves on), then wait for --until on the same page:
// checks that the page follows the farm live, without a reload.
// Exit code 0 when the condition held before the deadline, 1 otherwise.
import { spawn } from 'node:child_process';
import { mkdtempSync, readFileSync, writeFileSync, existsSync, rmSync, unlinkSync } from 'node:fs';
import { tmpdir } from 'node:os';
import { join } from 'node:path';

const args = {};
for (let i = 2; i < process.argv.length; i += 2) args[process.argv[i].replace(/^--/, '')] = process.argv[i + 1];
const timeoutMs = Number(args['timeout-ms'] || 120000);
const deadline = Date.now() + timeoutMs;
const width = Number(args.width || 1280), height = Number(args.height || 1000);
const profile = mkdtempSync(join(tmpdir(), 'impostor-chromium-'));
const out = { ok: false, value: null, console_errors: [], error: '' };

const chrome = spawn(args.chromium || 'chromium', [
  '--headless=new', '--no-sandbox', '--use-angle=swiftshader', '--enable-unsafe-swiftshader', '--no-first-run',
  '--no-default-browser-check', '--disable-extensions', '--disable-background-networking', '--mute-audio',
  `--window-size=${width},${height}`, `--user-data-dir=${profile}`, '--remote-debugging-port=0', 'about:blank',
], { stdio: ['ignore', 'ignore', 'pipe'] });
chrome.stderr.on('data', () => {});

const sleep = (ms) => new Promise((r) => setTimeout(r, ms));
function finish(code) {
  chrome.kill('SIGKILL');
  try { rmSync(profile, { recursive: true, force: true }); } catch {}
  // Exit once the report is written: stdout to a pipe is asynchronous, and
  // exiting at once cuts a large report (PNG data URLs) at the pipe's 64 KiB.
  process.stdout.write(JSON.stringify(out) + '\n', () => process.exit(code));
}
setTimeout(() => { out.error = out.error || 'deadline passed'; finish(1); }, timeoutMs + 5000).unref();

async function main() {
  const portFile = join(profile, 'DevToolsActivePort');
  while (!existsSync(portFile) || readFileSync(portFile, 'utf8').split('\n').length < 2) {
    if (Date.now() > deadline) throw new Error('chromium did not start');
    await sleep(100);
  }
  const port = readFileSync(portFile, 'utf8').split('\n')[0];
  const targets = await (await fetch(`http://127.0.0.1:${port}/json/list`)).json();
  const page = targets.find((t) => t.type === 'page');
  const ws = new WebSocket(page.webSocketDebuggerUrl);
  await new Promise((resolve, reject) => { ws.onopen = resolve; ws.onerror = () => reject(new Error('devtools socket')); });
  let nextId = 1;
  const pending = new Map();
  ws.onmessage = (m) => {
    const msg = JSON.parse(m.data);
    if (msg.id && pending.has(msg.id)) {
      const { resolve, reject } = pending.get(msg.id);
      pending.delete(msg.id);
      if (msg.error) reject(new Error(msg.error.message)); else resolve(msg.result);
    } else if (msg.method === 'Runtime.consoleAPICalled' && (msg.params.type === 'error' || msg.params.type === 'assert')) {
      out.console_errors.push(msg.params.args.map((a) => a.value ?? a.description ?? '').join(' '));
    } else if (msg.method === 'Runtime.exceptionThrown') {
      const d = msg.params.exceptionDetails;
      out.console_errors.push(`exception: ${d.exception?.description ?? d.text}`);
    } else if (msg.method === 'Log.entryAdded' && msg.params.entry.level === 'error') {
      out.console_errors.push(`${msg.params.entry.source}: ${msg.params.entry.text} ${msg.params.entry.url ?? ''}`);
    }
  };
  const send = (method, params = {}) => new Promise((resolve, reject) => {
    const id = nextId++;
    pending.set(id, { resolve, reject });
    ws.send(JSON.stringify({ id, method, params }));
  });
  await send('Runtime.enable');
  await send('Log.enable');
  await send('Page.enable');
  await send('Page.navigate', { url: args.url });
  const evaluate = async (expr) => {
    const r = await send('Runtime.evaluate', { expression: expr, returnByValue: true, awaitPromise: true });
    if (r.exceptionDetails) throw new Error(`${expr}: ${r.exceptionDetails.exception?.description ?? r.exceptionDetails.text}`);
    return r.result.value;
  };
  const waitFor = async (expr) => {
    while (true) {
      let held = false;
      try { held = Boolean(await evaluate(expr)); } catch { held = false; }  // page still loading
      if (held) return true;
      if (Date.now() > deadline) {
        out.error = `condition not met before the deadline: ${expr}`;
        return false;
      }
      await sleep(200);
    }
  };
  const screenshot = async (file) => {
    const shot = await send('Page.captureScreenshot', { format: 'png' });
    writeFileSync(file, Buffer.from(shot.data, 'base64'));
  };
  let held = true;
  if (args.first) {
    held = await waitFor(args.first);
    if (held && args['first-screenshot']) await screenshot(args['first-screenshot']);
    if (args['then-delete']) unlinkSync(args['then-delete']);
  }
  if (held) await waitFor(args.until);
  out.ok = !out.error;
  if (args.eval) out.value = await evaluate(args.eval);
  if (args.screenshot) await screenshot(args.screenshot);
  finish(out.ok ? 0 : 1);
}
main().catch((e) => { out.error = String(e && e.message ? e.message : e); finish(1); });
