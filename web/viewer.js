// SPDX-License-Identifier: GPL-3.0-or-later
// The cityatlas web viewer (three.js + 3DTilesRendererJS): opens the folder's
// 3D Tiles export, flies to it, shows load progress and, on a click, the
// picked building's attributes (EXT_mesh_features + EXT_structural_metadata).
//
// Query parameters (all optional):
//   tileset=URL        the tileset (default /3dtiles/tileset.json, as `cityatlas serve` hosts it)
//   sse=N              maximumScreenSpaceError in pixels (default 1 = tau: every atlas texel at most
//                      one pixel, the texel guarantee the build made; larger loads less)
//   camera=JSON        {"position":[x,y,z],"direction":[x,y,z],"up":[x,y,z],"fov_deg":60} in the
//                      tileset's world frame (ECEF when georeferenced); default: fly to the tileset
//   background=R,G,B   clear colour, linear (default 0.55,0.70,0.90, as `cityatlas render`)
//   bare=1             no overlays (screenshots)
// For tests, window.cityatlas holds the state (tiles loaded and visible, errors, ready when
// nothing is loading) and pick(x, y) -> the properties at a pixel (null: no building there).
import * as THREE from 'three';
import { OrbitControls } from 'three/addons/controls/OrbitControls.js';
import { KTX2Loader } from 'three/addons/loaders/KTX2Loader.js';
import { TilesRenderer } from '3d-tiles-renderer';
import { GLTFExtensionsPlugin } from '3d-tiles-renderer/plugins';

const params = new URLSearchParams(window.location.search);
const tilesetUrl = params.get('tileset') || '/3dtiles/tileset.json';
const sse = Number(params.get('sse') || 1);
const fixedCamera = params.get('camera') ? JSON.parse(params.get('camera')) : null;
const background = (params.get('background') || '0.55,0.70,0.90').split(',').map(Number);
if (params.get('bare') === '1') document.body.classList.add('bare');

const statusEl = document.getElementById('status');
const pickedEl = document.getElementById('picked');
const state = {
  tileset: tilesetUrl, started_ms: performance.now(), root_loaded: false, tiles_loaded: 0, tiles_failed: 0,
  tiles_visible: 0, tiles_active: 0, downloading: 0, parsing: 0, ready: false, ready_ms: null, errors: [],
};
window.cityatlas = { state, pick: null };

const renderer = new THREE.WebGLRenderer({ antialias: false, preserveDrawingBuffer: true });
renderer.setPixelRatio(1);
renderer.setSize(window.innerWidth, window.innerHeight);
renderer.setClearColor(new THREE.Color().setRGB(background[0], background[1], background[2], THREE.LinearSRGBColorSpace));
document.body.appendChild(renderer.domElement);

const camera = new THREE.PerspectiveCamera(fixedCamera?.fov_deg ?? 60, window.innerWidth / window.innerHeight, 0.5, 1e5);
const scene = new THREE.Scene();
const tiles = new TilesRenderer(tilesetUrl);
// KTX2 atlases (--web-textures ktx2): Basis Universal transcoded on this machine, from three's own files.
const ktxLoader = new KTX2Loader().setTranscoderPath('/_viewer/node_modules/three/examples/jsm/libs/basis/').detectSupport(renderer);
tiles.registerPlugin(new GLTFExtensionsPlugin({ metadata: true, ktxLoader }));
tiles.errorTarget = sse;
tiles.setCamera(camera);
tiles.setResolutionFromRenderer(camera, renderer);
scene.add(tiles.group);

tiles.addEventListener('load-root-tileset', () => { state.root_loaded = true; if (!fixedCamera) flyTo(); });
tiles.addEventListener('load-model', () => { state.tiles_loaded++; });
tiles.addEventListener('load-error', (e) => {
  state.tiles_failed++;
  state.errors.push(String(e.error?.message || e.error || 'load error') + ' ' + (e.url || ''));
});

let controls = null;
function flyTo() {
  const sphere = new THREE.Sphere();
  if (!tiles.getBoundingSphere(sphere)) return;
  const c = sphere.center, r = Math.max(sphere.radius, 1);
  // Up: the ellipsoid normal for a georeferenced (ECEF) tileset, else the local z.
  const up = c.length() > 1e6 ? c.clone().normalize() : new THREE.Vector3(0, 0, 1);
  const east = new THREE.Vector3(0, 0, 1).cross(up);
  if (east.lengthSq() < 1e-12) east.set(1, 0, 0);
  east.normalize();
  const north = up.clone().cross(east).normalize();
  camera.up.copy(up);
  camera.position.copy(c).addScaledVector(up, 1.3 * r).addScaledVector(north, -1.3 * r);
  camera.far = Math.max(1e5, 20 * r);
  camera.updateProjectionMatrix();
  camera.lookAt(c);
  controls = new OrbitControls(camera, renderer.domElement);
  controls.target.copy(c);
  controls.update();
}
if (fixedCamera) {
  const [px, py, pz] = fixedCamera.position, [dx, dy, dz] = fixedCamera.direction;
  camera.position.set(px, py, pz);
  camera.up.set(...(fixedCamera.up || [0, 0, 1]));
  camera.lookAt(px + dx, py + dy, pz + dz);
  camera.updateProjectionMatrix();
}

window.addEventListener('resize', () => {
  camera.aspect = window.innerWidth / window.innerHeight;
  camera.updateProjectionMatrix();
  renderer.setSize(window.innerWidth, window.innerHeight);
  tiles.setResolutionFromRenderer(camera, renderer);
});

// The properties of the building at pixel (x, y), or null.
function pick(x, y) {
  const ndc = new THREE.Vector2((x / window.innerWidth) * 2 - 1, -(y / window.innerHeight) * 2 + 1);
  const ray = new THREE.Raycaster();
  ray.setFromCamera(ndc, camera);
  for (const hit of ray.intersectObject(tiles.group, true)) {
    const features = hit.object.userData.meshFeatures, metadata = hit.object.userData.structuralMetadata;
    if (!features || !metadata || hit.faceIndex == null) continue;
    let bary = hit.barycoord;
    if (!bary) {
      const pos = hit.object.geometry.attributes.position, index = hit.object.geometry.index;
      const corner = (k) => new THREE.Vector3().fromBufferAttribute(pos, index ? index.getX(3 * hit.faceIndex + k) : 3 * hit.faceIndex + k)
        .applyMatrix4(hit.object.matrixWorld);
      bary = new THREE.Triangle(corner(0), corner(1), corner(2)).getBarycoord(hit.point, new THREE.Vector3());
    }
    const ids = features.getFeatures(hit.faceIndex, bary);
    const info = features.getFeatureInfo()[0];
    if (ids[0] == null || !info || info.propertyTable == null) continue;
    const [props] = metadata.getPropertyTableData([info.propertyTable], [ids[0]]);
    return { ...props, _feature_id: ids[0], _distance_m: hit.distance };
  }
  return null;
}
window.cityatlas.pick = pick;

function showPicked(props) {
  if (!props) { pickedEl.style.display = 'none'; return; }
  const rows = Object.entries(props).filter(([k, v]) => !k.startsWith('_') && v !== '' && v !== -1)
    .map(([k, v]) => `<tr><td>${escapeHtml(k)}</td><td>${escapeHtml(String(v))}</td></tr>`).join('');
  pickedEl.innerHTML = `<b>${escapeHtml(props.name || props.gml_id || 'building')}</b><table>${rows}</table>`;
  pickedEl.style.display = 'block';
}
function escapeHtml(s) {
  return s.replace(/[&<>"']/g, (c) => ({ '&': '&amp;', '<': '&lt;', '>': '&gt;', '"': '&quot;', "'": '&#39;' }[c]));
}
let down = null;
renderer.domElement.addEventListener('pointerdown', (e) => { down = [e.clientX, e.clientY]; });
renderer.domElement.addEventListener('pointerup', (e) => {
  if (down && Math.hypot(e.clientX - down[0], e.clientY - down[1]) < 4) showPicked(pick(e.clientX, e.clientY));
});

// Ready: the root is loaded and nothing has been downloading or parsing for 10 frames.
let quiet = 0;
function frame() {
  requestAnimationFrame(frame);
  if (controls) controls.update();
  camera.updateMatrixWorld();
  tiles.update();
  renderer.render(scene, camera);
  const s = tiles.stats || {};
  state.downloading = s.downloading ?? 0;
  state.parsing = s.parsing ?? 0;
  state.tiles_visible = tiles.visibleTiles ? tiles.visibleTiles.size : (s.visible ?? 0);
  if (tiles.visibleTiles) state.visible_uris = [...tiles.visibleTiles].map((t) => t.content?.uri || t.content?.url || '').sort();
  state.tiles_active = tiles.activeTiles ? tiles.activeTiles.size : (s.active ?? 0);
  const busy = !state.root_loaded || state.downloading > 0 || state.parsing > 0 || (s.queued ?? 0) > 0;
  quiet = busy ? 0 : quiet + 1;
  // Nothing loaded yet: the first requests may still be a few frames away.
  if (!state.ready && quiet >= (state.tiles_loaded > 0 ? 10 : 120)) { state.ready = true; state.ready_ms = performance.now() - state.started_ms; }
  if (state.ready && busy) state.ready = false;  // the camera moved: loading again
  statusEl.textContent = `${tilesetUrl}\n` +
    (state.ready ? `loaded: ${state.tiles_visible} tiles drawn (${state.tiles_loaded} downloaded)` :
      `loading: ${state.downloading} downloading, ${state.parsing} parsing, ${state.tiles_loaded} loaded`) +
    (state.tiles_failed ? `, ${state.tiles_failed} failed` : '') + '\nclick a building for its attributes';
}
frame();
