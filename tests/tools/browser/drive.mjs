// SPDX-License-Identifier: GPL-3.0-or-later
// Opens a 3D Tiles export in a real client inside Debian's headless chromium
// (puppeteer-core; WebGL on SwiftShader) and reports what it did: tiles loaded
// and drawn, the time until nothing was loading any more, console errors,
// page errors and failed requests, a screenshot at a given camera and the
// properties picked at given pixels.
//
//   node drive.mjs --client three|cesium --folder DIR --out RESULT.json
//                  [--camera CAMERA.json] [--size 640x360] [--screenshot SHOT.png]
//                  [--picks PICKS.json] [--sse 1] [--timeout 120] [--url URL]
//                  [--click X,Y] [--bare 0|1] [--metadata ID]
//
// three:  the cityatlas viewer (web/, three.js + 3DTilesRendererJS);
// cesium: CesiumJS (node_modules/cesium) on pages/cesium.html.
// Both are served by a small static server on 127.0.0.1 (an ephemeral port)
// started here: DIR at /, web/ at /_viewer/, CesiumJS at /cesium/, pages/ at
// /pages/. --url opens that page instead (the viewer as `cityatlas serve`
// hosts it) and serves nothing.
// CAMERA.json: {"position", "direction", "up": [x, y, z] in the tileset's world
// frame (ECEF when georeferenced), "fov_deg": vertical}. PICKS.json: [[x, y], ...].
// --click X,Y clicks there once ready and reports the viewer's attribute panel
// text (#picked); --bare 0 keeps the viewer's overlays (status, panel).
// --metadata ID (cesium): colour the tileset by the property texture ID (a
// computed texture) through a CustomShader, with cityatlas' ramp
// (render/core/computed_ramp.h) instead of the photo.
// Exit 0 when the client became ready with no error, 1 otherwise, 2 on usage.
import { createServer } from 'node:http';
import { createReadStream, existsSync, readFileSync, realpathSync, statSync, writeFileSync } from 'node:fs';
import path from 'node:path';
import { fileURLToPath } from 'node:url';
import { createRequire } from 'node:module';

const here = path.dirname(fileURLToPath(import.meta.url));
const require = createRequire(import.meta.url);

function usage(msg) {
  if (msg) console.error(`drive.mjs: ${msg}`);
  console.error('usage: node drive.mjs --client three|cesium --folder DIR --out RESULT.json [--camera F] [--size WxH] ' +
                '[--screenshot F] [--picks F] [--sse N] [--timeout S] [--url URL]');
  process.exit(2);
}
const opt = { size: '640x360', sse: '1', timeout: '120', bare: '1' };
for (let i = 2; i < process.argv.length; i += 2) {
  const k = process.argv[i];
  if (!k.startsWith('--') || i + 1 >= process.argv.length) usage(`bad argument ${k}`);
  opt[k.slice(2)] = process.argv[i + 1];
}
if (!['three', 'cesium'].includes(opt.client) || !opt.out || (!opt.folder && !opt.url)) usage();
const [width, height] = opt.size.split('x').map(Number);
const camera = opt.camera ? JSON.parse(readFileSync(opt.camera, 'utf8')) : null;
const picks = opt.picks ? JSON.parse(readFileSync(opt.picks, 'utf8')) : [];

const types = { '.json': 'application/json', '.glb': 'model/gltf-binary', '.html': 'text/html', '.js': 'text/javascript',
  '.mjs': 'text/javascript', '.css': 'text/css', '.png': 'image/png', '.jpg': 'image/jpeg', '.webp': 'image/webp',
  '.ktx2': 'image/ktx2', '.wasm': 'application/wasm', '.svg': 'image/svg+xml', '.xml': 'application/xml' };
const mounts = opt.url ? [] : [
  ['/_viewer/', path.resolve(here, '../../../web')],
  ['/cesium/', path.resolve(here, 'node_modules/cesium/Build/Cesium')],
  ['/pages/', path.resolve(here, 'pages')],
  ['/', path.resolve(opt.folder)],
];
function resolveRequest(urlPath) {
  if (urlPath === '/' || urlPath === '/index.html') return path.resolve(here, '../../../web/index.html');
  for (const [prefix, root] of mounts) {
    if (!urlPath.startsWith(prefix)) continue;
    const file = path.resolve(root, '.' + decodeURIComponent(urlPath.slice(prefix.length - 1)));
    try {
      const real = realpathSync(file);
      if (!real.startsWith(realpathSync(root) + path.sep) || !statSync(real).isFile()) return null;
      return real;
    } catch { return null; }
  }
  return null;
}
const served = { requests: 0, missing: [] };
const server = createServer((req, res) => {
  served.requests++;
  const file = resolveRequest(new URL(req.url, 'http://x').pathname);
  if (!file) {
    served.missing.push(req.url);
    res.writeHead(404, { 'Content-Type': 'text/plain' });
    return res.end('not found\n');
  }
  res.writeHead(200, { 'Content-Type': types[path.extname(file)] || 'application/octet-stream',
                       'Content-Length': statSync(file).size, 'Access-Control-Allow-Origin': '*' });
  createReadStream(file).pipe(res);
});

// One run in a fresh browser; throws when the browser itself fails (a crashed
// renderer process: "detached Frame", "Target closed"), which main retries once.
async function main() {
  let base = opt.url;
  if (!base) {
    if (!server.listening) await new Promise((ok) => server.listen(0, '127.0.0.1', ok));
    base = `http://127.0.0.1:${server.address().port}/`;
  }
  const q = new URLSearchParams({ bare: opt.bare, sse: opt.sse });
  if (camera) q.set('camera', JSON.stringify(camera));
  if (opt.metadata) q.set('metadata', opt.metadata);
  const page_url = opt.client === 'three'
    ? new URL(`?${q}`, base).href
    : new URL(`pages/cesium.html?${q}&tileset=${encodeURIComponent('/3dtiles/tileset.json')}`, base).href;

  const puppeteer = require('puppeteer-core');
  const executablePath = process.env.CHROMIUM || '/usr/bin/chromium';
  if (!existsSync(executablePath)) throw new Error(`${executablePath} is missing (Debian: apt-get install chromium)`);
  const browser = await puppeteer.launch({
    executablePath, headless: true, protocolTimeout: 600000,
    args: ['--headless=new', '--use-angle=swiftshader', '--enable-unsafe-swiftshader', '--ignore-gpu-blocklist',
           '--no-sandbox', '--disable-dev-shm-usage', '--no-first-run', '--no-default-browser-check',
           `--window-size=${width},${height}`],
  });
  const result = { client: opt.client, url: page_url, width, height, console_errors: [], page_errors: [],
                   failed_requests: [], ready: false };
  try {
    const page = await browser.newPage();
    page.on('error', (e) => result.page_errors.push(`page crashed: ${e.message || e}`));
    await page.setViewport({ width, height, deviceScaleFactor: 1 });
    page.on('console', (m) => { if (m.type() === 'error') result.console_errors.push(m.text().slice(0, 500)); });
    page.on('pageerror', (e) => result.page_errors.push(String(e.message || e).slice(0, 500)));
    page.on('requestfailed', (r) => result.failed_requests.push(`${r.url()}: ${r.failure()?.errorText}`));
    page.on('response', (r) => { if (r.status() >= 400) result.failed_requests.push(`${r.url()}: HTTP ${r.status()}`); });
    const t0 = Date.now();
    await page.goto(page_url, { waitUntil: 'load', timeout: 60000 });
    const deadline = t0 + Number(opt.timeout) * 1000;
    let state = null;
    while (Date.now() < deadline) {
      state = await page.evaluate(() => window.cityatlas && { ...window.cityatlas.state });
      if (state && state.ready) break;
      if (result.page_errors.length) break;
      await new Promise((ok) => setTimeout(ok, 250));
    }
    result.wall_ms_to_ready = Date.now() - t0;
    result.state = state;
    result.ready = !!(state && state.ready);
    if (result.ready && opt.screenshot) await page.screenshot({ path: opt.screenshot, type: 'png' });
    result.picks = [];
    for (const [x, y] of picks) {
      const r = await page.evaluate((px, py) => window.cityatlas.pick(px, py), x, y);
      result.picks.push({ x, y, properties: r });
    }
    if (opt.click) {
      const [x, y] = opt.click.split(',').map(Number);
      await page.mouse.click(x, y);
      await new Promise((ok) => setTimeout(ok, 300));
      result.clicked_text = await page.evaluate(() => document.getElementById('picked')?.innerText ?? null);
      result.status_text = await page.evaluate(() => document.getElementById('status')?.innerText ?? null);
    }
  } finally {
    await browser.close().catch(() => {});
  }
  result.served = served;
  writeFileSync(opt.out, JSON.stringify(result, null, 1) + '\n');
  const errors = result.console_errors.length + result.page_errors.length + result.failed_requests.length +
                 (result.state?.errors?.length || 0);
  console.log(`${opt.client}: ${result.ready ? 'ready' : 'NOT READY'} after ${result.wall_ms_to_ready} ms, ` +
              `${result.state?.tiles_loaded ?? 0} tiles loaded, ${result.state?.tiles_visible ?? 0} drawn, ${errors} errors`);
  process.exit(result.ready && errors === 0 ? 0 : 1);
}
const crashed = (e) => /detached Frame|Target closed|Session closed|Protocol error/.test(String(e && (e.message || e)));
main().catch(async (e) => {
  if (!crashed(e)) { console.error(`drive.mjs: ${e.stack || e}`); process.exit(1); }
  // The browser, not the page under test, failed (seen once under heavy load): one more try, said so.
  console.error(`drive.mjs: the browser failed (${String(e.message || e).split('\n')[0]}); trying once more`);
  await main().catch((e2) => { console.error(`drive.mjs: ${e2.stack || e2}`); process.exit(1); });
});
