// A small static web server for the tests (Node.js http, 127.0.0.1, port
// 0): serves directories under URL prefixes, logs every request, and can
// misbehave on purpose: flip one byte of chosen files (a tampered mirror),
// answer an HTTP status instead (a broken mirror) or stop mid-body (a stalled
// one). Release trees get the caching headers release_format.md asks for
// (blobs and catalogs immutable, channel files short-lived with an ETag),
// and every answer allows any origin (mirrors are other origins than the
// page).
import { createHash } from 'node:crypto';
import { readFileSync, statSync } from 'node:fs';
import { createServer } from 'node:http';
import { extname, join, normalize, sep } from 'node:path';

const TYPES = {
  '.html': 'text/html; charset=utf-8', '.js': 'text/javascript; charset=utf-8', '.mjs': 'text/javascript; charset=utf-8',
  '.json': 'application/json', '.wasm': 'application/wasm', '.png': 'image/png', '.glsl': 'text/plain; charset=utf-8',
  '.css': 'text/css', '.ktx2': 'image/ktx2',
};

// routes: [{prefix: '/three/', dir}]; options: {tamper(urlPath) -> bool,
// fail(urlPath) -> status | 0, stall(urlPath) -> bool}. Resolves to
// {url, port, requests: [{method, path}], close()}.
export function startStaticServer(routes, options = {}) {
  const requests = [];
  const server = createServer((req, res) => {
    const path = decodeURIComponent(new URL(req.url, 'http://x').pathname);
    requests.push({ method: req.method, path });
    res.setHeader('Access-Control-Allow-Origin', '*');
    res.setHeader('Access-Control-Allow-Headers', '*');
    if (req.method === 'OPTIONS') {
      res.writeHead(204);
      res.end();
      return;
    }
    const status = options.fail ? options.fail(path) : 0;
    if (status) {
      res.writeHead(status, { 'Content-Type': 'text/html' });
      res.end(`<html><body>error ${status}</body></html>`);
      return;
    }
    const route = routes.find((r) => path.startsWith(r.prefix));
    if (!route) {
      res.writeHead(404);
      res.end('no route');
      return;
    }
    const rel = normalize(path.slice(route.prefix.length));
    if (rel.startsWith('..') || rel.includes(`${sep}..`)) {
      res.writeHead(400);
      res.end('bad path');
      return;
    }
    const file = join(route.dir, rel);
    let body;
    try {
      if (!statSync(file).isFile()) throw new Error('not a file');
      body = readFileSync(file);
    } catch {
      res.writeHead(404, { 'Content-Type': 'text/plain' });
      res.end(`not found: ${path}`);
      return;
    }
    if (options.tamper && options.tamper(path)) {
      body = Buffer.from(body);
      body[body.length >> 1] ^= 0x01;  // one flipped bit, same size
    }
    const headers = { 'Content-Type': TYPES[extname(file)] || 'application/octet-stream', 'Content-Length': body.length };
    if (path.includes('/v1/blobs/') || path.includes('/v1/catalogs/')) {
      headers['Cache-Control'] = 'public, max-age=31536000, immutable';
    } else if (path.includes('/v1/channels/')) {
      const etag = `"${createHash('sha256').update(body).digest('hex').slice(0, 16)}"`;
      headers['Cache-Control'] = 'max-age=10';
      headers.ETag = etag;
      if (req.headers['if-none-match'] === etag) {
        res.writeHead(304, { ETag: etag, 'Cache-Control': 'max-age=10' });
        res.end();
        return;
      }
    } else {
      headers['Cache-Control'] = 'no-store';
    }
    res.writeHead(200, headers);
    if (options.stall && options.stall(path)) {
      res.write(body.subarray(0, body.length >> 1));  // then nothing more
      return;
    }
    res.end(req.method === 'HEAD' ? undefined : body);
  });
  return new Promise((resolve) => {
    server.listen(0, '127.0.0.1', () => {
      const { port } = server.address();
      resolve({
        url: `http://127.0.0.1:${port}`, port, requests,
        close: () => new Promise((done) => {
          server.closeAllConnections();
          server.close(() => done());
        }),
      });
    });
  });
}
