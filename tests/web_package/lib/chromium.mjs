// Headless Chromium driven over the DevTools protocol (Node.js 20's
// WebSocket, run node with --experimental-websocket), for the browser test:
// Debian's /usr/bin/chromium on SwiftShader with a fresh profile, one page,
// navigate-and-wait, evaluate (awaiting promises), and the network requests
// the page made. No npm dependency.
import { spawn } from 'node:child_process';
import { existsSync, mkdtempSync, readFileSync, rmSync } from 'node:fs';
import { tmpdir } from 'node:os';
import { join } from 'node:path';

const sleep = (ms) => new Promise((r) => setTimeout(r, ms));

export const CHROMIUM_FLAGS = [
  '--headless=new', '--use-angle=swiftshader', '--enable-unsafe-swiftshader', '--no-sandbox', '--disable-gpu',
  '--no-first-run', '--disable-background-networking', '--disable-component-update', '--disable-sync',
  '--no-default-browser-check', '--disable-extensions', '--mute-audio', '--window-size=800,800',
];

// Starts Chromium; resolves to a Browser. `deadlineMs` bounds the start;
// `extraFlags` follow CHROMIUM_FLAGS.
export async function launchChromium(executable = '/usr/bin/chromium', deadlineMs = 60000, extraFlags = []) {
  const profile = mkdtempSync(join(tmpdir(), 'impostor-three-chromium-'));
  const child = spawn(executable, [...CHROMIUM_FLAGS, ...extraFlags, `--user-data-dir=${profile}`, '--remote-debugging-port=0', 'about:blank'],
    // Its own process group, so close() can end the renderer and GPU processes too.
    { stdio: ['ignore', 'ignore', 'pipe'], detached: true });
  let stderr = '';
  child.stderr.on('data', (d) => { stderr = (stderr + d).slice(-4000); });
  const portFile = join(profile, 'DevToolsActivePort');
  const until = Date.now() + deadlineMs;
  while (!existsSync(portFile) || readFileSync(portFile, 'utf8').split('\n').length < 2) {
    if (child.exitCode !== null || Date.now() > until) {
      child.kill('SIGKILL');
      rmSync(profile, { recursive: true, force: true });
      throw new Error(`chromium did not start: ${stderr}`);
    }
    await sleep(100);
  }
  const port = readFileSync(portFile, 'utf8').split('\n')[0];
  const targets = await (await fetch(`http://127.0.0.1:${port}/json/list`)).json();
  const page = targets.find((t) => t.type === 'page');
  const ws = new WebSocket(page.webSocketDebuggerUrl);
  await new Promise((resolve, reject) => {
    ws.onopen = resolve;
    ws.onerror = () => reject(new Error('devtools socket'));
  });
  return new Browser(child, profile, ws);
}

export class Browser {
  constructor(child, profile, ws) {
    this.child = child;
    this.profile = profile;
    this.ws = ws;
    this.nextId = 1;
    this.pending = new Map();
    this.listeners = [];
    this.consoleErrors = [];
    this.requests = [];  // every URL the page requested: {url, fromCache}
    ws.onmessage = (m) => {
      const msg = JSON.parse(m.data);
      if (msg.id && this.pending.has(msg.id)) {
        const { resolve, reject } = this.pending.get(msg.id);
        this.pending.delete(msg.id);
        if (msg.error) reject(new Error(msg.error.message));
        else resolve(msg.result);
        return;
      }
      if (msg.method === 'Network.requestWillBeSent') this.requests.push({ url: msg.params.request.url });
      if (msg.method === 'Runtime.exceptionThrown') {
        const d = msg.params.exceptionDetails;
        this.consoleErrors.push(`exception: ${d.exception?.description ?? d.text}`);
      }
      if (msg.method === 'Runtime.consoleAPICalled' && msg.params.type === 'error') {
        this.consoleErrors.push(msg.params.args.map((a) => a.value ?? a.description ?? '').join(' '));
      }
      for (const l of this.listeners) l(msg);
    };
  }

  send(method, params = {}) {
    return new Promise((resolve, reject) => {
      const id = this.nextId++;
      this.pending.set(id, { resolve, reject });
      this.ws.send(JSON.stringify({ id, method, params }));
    });
  }

  async start() {
    await this.send('Runtime.enable');
    await this.send('Network.enable');
    await this.send('Page.enable');
    return this;
  }

  // Navigates and waits for the load event (module scripts have run).
  async open(url, timeoutMs = 60000) {
    const loaded = new Promise((resolve, reject) => {
      const timer = setTimeout(() => reject(new Error(`${url}: no load event in ${timeoutMs} ms`)), timeoutMs);
      const l = (msg) => {
        if (msg.method === 'Page.loadEventFired') {
          clearTimeout(timer);
          this.listeners = this.listeners.filter((x) => x !== l);
          resolve();
        }
      };
      this.listeners.push(l);
    });
    const r = await this.send('Page.navigate', { url });
    if (r.errorText) throw new Error(`${url}: ${r.errorText}`);
    await loaded;
  }

  // The value of `expression` (a promise is awaited), by value.
  async evaluate(expression, timeoutMs = 120000) {
    let timer;
    const r = await Promise.race([
      this.send('Runtime.evaluate', { expression, returnByValue: true, awaitPromise: true }),
      new Promise((_, reject) => { timer = setTimeout(() => reject(new Error(`${expression}: no answer in ${timeoutMs} ms`)), timeoutMs); }),
    ]).finally(() => clearTimeout(timer));
    if (r.exceptionDetails) throw new Error(`${expression}: ${r.exceptionDetails.exception?.description ?? r.exceptionDetails.text}`);
    return r.result.value;
  }

  // Ends Chromium (Browser.close, then its process group if it lingers) and
  // removes its profile once every process of it has exited.
  async close() {
    const exited = this.child.exitCode !== null || this.child.signalCode !== null
      ? Promise.resolve() : new Promise((r) => this.child.once('exit', r));
    await Promise.race([this.send('Browser.close').catch(() => {}), sleep(2000)]);
    try { this.ws.close(); } catch { /* closing anyway */ }
    const timer = setTimeout(() => this.killGroup(), 5000);
    await exited;
    clearTimeout(timer);
    this.killGroup();  // children the browser process left behind, if any
    rmSync(this.profile, { recursive: true, force: true, maxRetries: 10, retryDelay: 200 });
  }

  killGroup() {
    try {
      process.kill(-this.child.pid, 'SIGKILL');
    } catch {
      // the group has already gone
    }
  }
}
