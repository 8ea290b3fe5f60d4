// One job: parameters, progress, stage timings, warnings, errors, attempts
// and its worker, quality figures. Polls until the job ends.
import { getJson, grpcCodeName, el, link, progressBar, replace, reportError, table, layoutName } from './common.js';

const POLL_MS = 2000;
const jobId = decodeURIComponent(location.pathname.split('/').pop());

function kv(pairs) {
  const dl = el('dl', { class: 'kv' });
  for (const [k, v] of pairs) dl.append(el('dt', {}, k), el('dd', {}, v instanceof Node ? v : String(v ?? '—')));
  return dl;
}

// Job.attempt_history (docs/http_api.md): one row per lease, oldest first.
function attemptsTable(j) {
  const history = j.attempt_history || [];
  if (!history.length) return el('span', { class: 'muted' }, 'not leased yet');
  const time = (ms) => (ms ? new Date(ms).toLocaleTimeString() : '—');
  const rows = history.map((a) => [String(a.attempt), a.worker_id, a.device || '—', time(a.leased_ms), time(a.ended_ms),
    a.ended_ms ? `${((a.ended_ms - a.leased_ms) / 1000).toFixed(1)} s` : '—',
    el('td', { class: `state-${a.outcome === 'succeeded' ? 'succeeded' : a.outcome === 'running' ? 'running' : 'failed'}` }, a.outcome),
    el('td', { class: 'wrap' }, a.message || '')]);
  const t = table(['#', 'worker', 'device', 'leased', 'ended', 'held', 'outcome', 'message'], rows, 'attempts');
  if (!j.attempt_history_dropped) return t;
  return el('div', {}, el('span', { class: 'muted' }, `${j.attempt_history_dropped} older leases not kept`), t);
}

async function refresh() {
  const j = await getJson(`/api/v1/jobs/${encodeURIComponent(jobId)}`);
  document.getElementById('title').textContent = j.job_id;
  const terminal = ['succeeded', 'failed', 'cancelled'].includes(j.state);
  replace('job', kv([
    ['state', el('span', { class: `state-${j.state}`, 'data-testid': 'job-state' }, j.state)],
    ['progress', progressBar(j.progress)], ['stage', j.stage], ['attempts', j.attempts], ['worker (last lease)', j.worker_id || '—'],
    ['requester', j.requester || '—'], ['priority', `${j.priority} (queue runs it at ${j.lease_priority})`],
    ['shares the bake of', j.leader_job_id ? link(`/jobs/${j.leader_job_id}`, j.leader_job_id) : '—'],
    ['cache key', j.state === 'succeeded' ? link(`/results/${j.cache_key}`, j.cache_key) : j.cache_key],
    ['cached', j.cached], ['created', new Date(j.created_ms).toLocaleString()], ['updated', new Date(j.updated_ms).toLocaleString()],
    ['error', j.error && j.error.message ? `${grpcCodeName(j.error.code)}: ${j.error.message}` : '—'],
    ['mesh', `${j.mesh.entry.path} (${j.mesh.files.length} more files)`]]));
  replace('attempts', attemptsTable(j));
  replace('params', kv(Object.entries(j.parameters).filter(([, v]) => v !== '' && v !== 0 && v !== false && !(Array.isArray(v) && !v.length))
    .map(([k, v]) => [k, k === 'layout' ? layoutName(v) : typeof v === 'object' ? JSON.stringify(v) : v])));
  const r = j.result;
  replace('timings', r ? kv(Object.entries(r.timings).map(([k, v]) => [k.replace('_seconds', ''), `${v.toFixed(3)} s`])) : el('span', { class: 'muted' }, 'no result yet'));
  replace('quality', r && r.quality && r.quality.views ? kv(Object.entries(r.quality).filter(([, v]) => !Array.isArray(v) || v.length)
    .map(([k, v]) => [k, typeof v === 'number' && !Number.isInteger(v) ? v.toFixed(4) : JSON.stringify(v)])) : el('span', { class: 'muted' }, '—'));
  replace('warnings', r && r.warnings.length ? el('ul', {}, ...r.warnings.map((w) => el('li', {}, w))) : el('span', { class: 'muted' }, 'none'));
  document.getElementById('updated').textContent = `updated ${new Date().toLocaleTimeString()}`;
  return terminal;
}

async function loop() {
  let terminal = false;
  try {
    terminal = await refresh();
  } catch (e) {
    reportError(String(e));
    // An unknown job, a bad id or a refused token will not change by
    // asking again: say it once and stop.
    if (e.status >= 400 && e.status < 500) terminal = true;
  }
  if (!terminal) setTimeout(loop, POLL_MS);
  else document.body.dataset.final = '1';
}
loop();
