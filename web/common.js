// Shared by the dashboard pages: JSON fetches, formatting, and an error
// panel (#errors) that every uncaught error or console.error also lands in,
// so a headless browser test sees them in the DOM.
const errorsBox = () => document.getElementById('errors');
export function reportError(message) {
  const box = errorsBox();
  if (box) box.textContent += message + '\n';
}
window.addEventListener('error', (e) => reportError(`error: ${e.message}`));
window.addEventListener('unhandledrejection', (e) => reportError(`unhandled rejection: ${e.reason}`));
const originalConsoleError = console.error.bind(console);
console.error = (...args) => { reportError(args.join(' ')); originalConsoleError(...args); };

export async function getJson(path) {
  const res = await fetch(path, { cache: 'no-store' });
  const body = await res.json().catch(() => ({}));
  if (!res.ok) {
    const error = new Error(`${path}: ${res.status} ${body.error ? body.error.message : ''}`);
    error.status = res.status;
    throw error;
  }
  return body;
}

// A layout as users write it (--layout hemi-octahedral, manifest.json) from
// the JSON API's enum name (LAYOUT_HEMI_OCTAHEDRAL); the same as
// impostor-three's layoutName, kept here so the overview and job pages need
// no import map.
export function layoutName(layout) {
  if (!layout || layout === 'LAYOUT_UNSPECIFIED') return 'octahedral';
  return String(layout).replace(/^LAYOUT_/, '').toLowerCase().replace(/_/g, '-');
}

// gRPC status codes by number (a job's error.code), as the CLI names them.
const GRPC_CODES = ['OK', 'CANCELLED', 'UNKNOWN', 'INVALID_ARGUMENT', 'DEADLINE_EXCEEDED', 'NOT_FOUND',
  'ALREADY_EXISTS', 'PERMISSION_DENIED', 'RESOURCE_EXHAUSTED', 'FAILED_PRECONDITION', 'ABORTED', 'OUT_OF_RANGE',
  'UNIMPLEMENTED', 'INTERNAL', 'UNAVAILABLE', 'DATA_LOSS', 'UNAUTHENTICATED'];
export function grpcCodeName(code) {
  return GRPC_CODES[code] || `code ${code}`;
}

export function el(tag, attrs = {}, ...children) {
  const e = document.createElement(tag);
  for (const [k, v] of Object.entries(attrs)) {
    if (k === 'class') e.className = v; else if (k.startsWith('data-')) e.setAttribute(k, v); else e[k] = v;
  }
  for (const c of children) e.append(c instanceof Node ? c : document.createTextNode(c ?? ''));
  return e;
}

export function link(href, text) { return el('a', { href }, text); }
export function shortId(id) { return id && id.length > 16 ? id.slice(0, 12) + '…' : id || ''; }
export function bytes(n) {
  const units = ['B', 'KiB', 'MiB', 'GiB', 'TiB'];
  let i = 0;
  while (n >= 1024 && i < units.length - 1) { n /= 1024; ++i; }
  return `${n.toFixed(i ? 1 : 0)} ${units[i]}`;
}
export function age(ms, now) {
  const s = Math.max(0, (now - ms) / 1000);
  if (s < 90) return `${s.toFixed(0)} s`;
  if (s < 5400) return `${(s / 60).toFixed(0)} min`;
  return `${(s / 3600).toFixed(1)} h`;
}
export function progressBar(p) {
  return el('span', {}, el('span', { class: 'bar' }, Object.assign(el('div'), { style: `width:${(p * 100).toFixed(0)}%` })),
    ` ${(p * 100).toFixed(0)}%`);
}
export function stateCell(state) { return el('td', { class: `state-${state}` }, state); }
export function table(headers, rows, testid) {
  const t = el('table', testid ? { 'data-testid': testid } : {});
  t.append(el('tr', {}, ...headers.map((h) => el('th', {}, h))));
  for (const r of rows) t.append(el('tr', {}, ...r.map((c) => (c instanceof HTMLElement && c.tagName === 'TD' ? c : el('td', {}, c)))));
  return t;
}
export function replace(id, node) { const old = document.getElementById(id); old.replaceChildren(node); }
