// The queue overview: polls the JSON API every POLL_MS (the page is at most
// that far behind the farm).
import { getJson, el, link, shortId, bytes, age, progressBar, stateCell, table, replace, reportError, layoutName } from './common.js';

const POLL_MS = 2000;
const samples = [];  // [now_ms, jobs_completed] over the last minute, for throughput

function card(key, value, testid) {
  return el('div', { class: 'card', 'data-testid': testid }, el('div', { class: 'v' }, String(value)), el('div', { class: 'k' }, key));
}

function jobRow(j, now, withProgress) {
  const row = [el('td', {}, link(`/jobs/${j.job_id}`, shortId(j.job_id))), j.product, stateCell(j.state)];
  if (withProgress) row.push(el('td', {}, progressBar(j.progress)), j.stage);
  row.push(String(j.priority), j.requester || '—', j.worker_id || '—', age(j.created_ms, now));
  return row;
}

async function refresh() {
  const [summary, running, queued, recent, workers, results, pools] = await Promise.all([
    getJson('/api/v1/summary'), getJson('/api/v1/jobs?state=running&page_size=100'),
    getJson('/api/v1/jobs?state=queued&page_size=50'), getJson('/api/v1/jobs?page_size=30'),
    getJson('/api/v1/workers'), getJson('/api/v1/results?page_size=10'), getJson('/api/v1/pools')]);
  const now = summary.now_ms;
  samples.push([now, summary.jobs_completed]);
  while (samples.length > 2 && now - samples[0][0] > 60000) samples.shift();
  const [t0, c0] = samples[0];
  const perMinute = now > t0 ? ((summary.jobs_completed - c0) * 60000) / (now - t0) : 0;
  const j = summary.jobs;
  replace('summary', el('div', { class: 'cards' },
    card('queued', j.queued, 'count-queued'), card('running', j.running, 'count-running'),
    card('succeeded', j.succeeded, 'count-succeeded'), card('failed', j.failed, 'count-failed'),
    card('cancelled', j.cancelled, 'count-cancelled'), card('bakes / min', perMinute.toFixed(1), 'throughput'),
    card('cache hit ratio', `${(summary.cache_hit_ratio * 100).toFixed(0)}%`, 'hit-ratio'),
    card('workers busy / idle / offline', `${summary.workers.busy} / ${summary.workers.idle} / ${summary.workers.offline}`, 'workers'),
    card('store', bytes(summary.store_bytes), 'store')));
  const headers = ['job', 'product', 'state', 'progress', 'stage', 'priority', 'requester', 'worker', 'age'];
  replace('running', running.jobs.length ? table(headers, running.jobs.map((x) => jobRow(x, now, true)), 'running-jobs')
    : el('span', { class: 'muted', 'data-testid': 'running-jobs' }, 'nothing running'));
  replace('queued', queued.jobs.length
    ? table(['job', 'product', 'state', 'priority', 'requester', 'worker', 'age'], queued.jobs.map((x) => jobRow(x, now, false)), 'queued-jobs')
    : el('span', { class: 'muted', 'data-testid': 'queued-jobs' }, 'queue empty'));
  const finished = recent.jobs.filter((x) => ['succeeded', 'failed', 'cancelled'].includes(x.state));
  replace('finished', table(['job', 'product', 'state', 'priority', 'requester', 'worker', 'age', 'result'],
    finished.map((x) => [...jobRow(x, now, false),
      el('td', {}, x.state === 'succeeded' ? link(`/results/${x.cache_key}`, x.cached ? 'cached' : 'view') : (x.error ? x.error.message : ''))]),
    'finished-jobs'));
  replace('workers', table(['worker', 'state', 'device', 'can bake', 'holds', 'done', 'failed', 'last seen'],
    workers.workers.map((w) => [w.worker_id, stateCell(w.state), w.device || '—', capabilities(w.capabilities),
      el('td', {}, ...w.job_ids.map((id) => link(`/jobs/${id}`, shortId(id) + ' '))),
      String(w.jobs_completed), String(w.jobs_failed), w.last_seen_ms ? age(w.last_seen_ms, now) + ' ago' : '—']), 'workers-table'));
  // Pools and shares (issue 44): shown only on a server with --pools.
  document.getElementById('pools-section').hidden = pools.pools.length === 0;
  replace('pools', table(['pool', 'tag', 'workers', 'running', 'share', 'guaranteed', 'team running'],
    pools.pools.flatMap((p) => (p.shares.length ? p.shares : [null]).map((s) => [p.name, p.tag, String(p.workers),
      String(p.running), s ? `${s.team} ${s.percent}%` : '—', s ? String(s.guaranteed_workers) : '—',
      s ? String(s.running) : '—'])), 'pools-table'));
  replace('results', table(['result', 'product', 'layout', 'frames', 'resolution', 'IoU', 'PSNR', 'size', 'baked'],
    results.results.map((r) => [el('td', {}, link(`/results/${r.cache_key}`, shortId(r.cache_key))), r.product, layoutName(r.layout),
      String(r.frames), String(r.resolution), r.silhouette_iou_mean?.toFixed(3) ?? '—', r.albedo_psnr_shared_db_mean?.toFixed(1) ?? '—',
      bytes(r.bytes), age(r.created_ms, now) + ' ago']), 'results-table'));
  document.getElementById('updated').textContent = `updated ${new Date(now).toLocaleTimeString()}`;
  document.body.dataset.refreshes = String(Number(document.body.dataset.refreshes || 0) + 1);
}

async function loop() {
  try { await refresh(); } catch (e) { reportError(String(e)); }
  setTimeout(loop, POLL_MS);
}
loop();

// What a worker reported it can do (issue 44): device kind, its memory
// totals, the KTX2 encoder, its tags; '—' for a worker that reports nothing.
function capabilities(c) {
  if (!c) return '—';
  const parts = [c.device_kind || 'device'];
  if (c.host_memory_bytes) parts.push(`${bytes(c.host_memory_bytes)} host`);
  if (c.device_memory_bytes && c.device_kind !== 'cpu') parts.push(`${bytes(c.device_memory_bytes)} device`);
  parts.push(c.ktx2_encoder ? 'KTX2' : 'no KTX2');
  if (c.tags && c.tags.length) parts.push(c.tags.join(','));
  return parts.join(' · ');
}
