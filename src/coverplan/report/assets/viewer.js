// coverplan flight report viewer: scene, flight path, shots and per-sample coverage.
import * as THREE from 'three';
import { OrbitControls } from 'three/addons/controls/OrbitControls.js';

const data = JSON.parse(document.getElementById('report-data').textContent);

function decode(b64, Type) {
  const bytes = Uint8Array.from(atob(b64), (c) => c.charCodeAt(0));
  return new Type(bytes.buffer);
}

const LEG_COLOURS = [new THREE.Color(0x2b6cb0), new THREE.Color(0xdd6b20), new THREE.Color(0x805ad5)];
const VIEW_COLOURS = [new THREE.Color(0xe53e3e), new THREE.Color(0xed8936), new THREE.Color(0x9ae6b4),
  new THREE.Color(0x2f855a)];

const host = document.getElementById('view');
const renderer = new THREE.WebGLRenderer({ antialias: true, preserveDrawingBuffer: true });
renderer.setPixelRatio(window.devicePixelRatio || 1);
renderer.setClearColor(0xf7fafc);
host.appendChild(renderer.domElement);

const scene = new THREE.Scene();
const camera = new THREE.PerspectiveCamera(45, 1, data.radius * 0.01, data.radius * 50);
camera.up.set(0, 0, 1);
const centre = new THREE.Vector3(...data.centre);
camera.position.copy(centre).add(new THREE.Vector3(-0.9, -1.3, 0.75).multiplyScalar(data.radius));
const controls = new OrbitControls(camera, renderer.domElement);
controls.target.copy(centre);
controls.update();

scene.add(new THREE.AmbientLight(0xffffff, 0.55));
const sun = new THREE.DirectionalLight(0xffffff, 0.9);
sun.position.set(-1, -2, 3);
scene.add(sun);

const layers = {};

function addLayer(name, object) {
  layers[name] = object;
  scene.add(object);
}

// Meshes: targets grey, obstacles red, the terrain (when given) earth-coloured.
// Zones: keep-out prisms translucent red, keep-in translucent green.
const groups = {
  target: new THREE.Group(), obstacle: new THREE.Group(), terrain: new THREE.Group(),
  'keep-out': new THREE.Group(), 'keep-in': new THREE.Group(),
};
const LOOK = {
  target: { color: 0xa0aec0, opacity: 0.55, depthWrite: false },
  obstacle: { color: 0xc53030, opacity: 0.7, depthWrite: true },
  terrain: { color: 0xb7a77a, opacity: 0.8, depthWrite: true },
  'keep-out': { color: 0xe53e3e, opacity: 0.18, depthWrite: false },
  'keep-in': { color: 0x38a169, opacity: 0.08, depthWrite: false },
};
for (const m of data.meshes) {
  const g = new THREE.BufferGeometry();
  g.setAttribute('position', new THREE.BufferAttribute(decode(m.positions, Float32Array), 3));
  g.setIndex(new THREE.BufferAttribute(decode(m.indices, Uint32Array), 1));
  g.computeVertexNormals();
  const role = m.role in groups ? m.role : 'obstacle';
  const mat = new THREE.MeshLambertMaterial({
    flatShading: true, side: THREE.DoubleSide, transparent: true, ...LOOK[role],
  });
  groups[role].add(new THREE.Mesh(g, mat));
}
addLayer('targets', groups.target);
addLayer('obstacles', groups.obstacle);
addLayer('terrain', groups.terrain);
const zones = new THREE.Group();
zones.add(groups['keep-out'], groups['keep-in']);
addLayer('zones', zones);

// Surface samples coloured by valid views (0, 1, 2, 3+) or by achieved GSD.
const samplePos = decode(data.samples.positions, Float32Array);
const views = decode(data.samples.views, Uint8Array);
const gsd = decode(data.samples.gsd, Float32Array);
const status = decode(data.samples.status, Uint8Array);
// With a simulation: 1 where SfM put a 3D point within 0.2 m of the sample.
const sfmRecon = data.simulation ? decode(data.simulation.reconstructed, Uint8Array) : null;
const sampleGeom = new THREE.BufferGeometry();
sampleGeom.setAttribute('position', new THREE.BufferAttribute(samplePos, 3));
const sampleColours = new Float32Array(samplePos.length);
sampleGeom.setAttribute('color', new THREE.BufferAttribute(sampleColours, 3));
const pointSize = data.sample_size;
addLayer('samples', new THREE.Points(sampleGeom, new THREE.PointsMaterial({ size: pointSize, vertexColors: true })));

function colourSamples(mode) {
  const c = new THREE.Color();
  for (let i = 0; i < views.length; i++) {
    if (mode === 'sfm') {
      c.set(sfmRecon && sfmRecon[i] ? 0x2f855a : 0xe53e3e);
    } else if (mode === 'gsd') {
      if (!(gsd[i] > 0)) c.set(0x718096);
      else {
        const t = Math.min(Math.max(gsd[i] / data.params.gsd_m, 0), 1);
        c.setHSL(0.33 * (1 - t), 0.75, 0.45);
      }
    } else {
      c.copy(VIEW_COLOURS[Math.min(views[i], 3)]);
    }
    c.toArray(sampleColours, 3 * i);
  }
  sampleGeom.attributes.color.needsUpdate = true;
}
colourSamples('views');

// Uncovered samples stand out: magenta when reachable but missed, purple when unreachable.
const missed = [];
const missedColours = [];
for (let i = 0; i < status.length; i++) {
  if (status[i] === 0) continue;
  missed.push(samplePos[3 * i], samplePos[3 * i + 1], samplePos[3 * i + 2]);
  (status[i] === 1 ? new THREE.Color(0xd53f8c) : new THREE.Color(0x553c9a)).toArray(missedColours, missedColours.length);
}
const missedGeom = new THREE.BufferGeometry();
missedGeom.setAttribute('position', new THREE.Float32BufferAttribute(missed, 3));
missedGeom.setAttribute('color', new THREE.Float32BufferAttribute(missedColours, 3));
addLayer('uncovered', new THREE.Points(missedGeom, new THREE.PointsMaterial({ size: pointSize * 2.2, vertexColors: true })));

// Flight path coloured by leg, or by battery flight when there are several.
const wp = decode(data.waypoints.positions, Float32Array);
const leg = decode(data.waypoints.leg, Uint8Array);
const flightOf = decode(data.waypoints.flight, Uint8Array);
const FLIGHT_COLOURS = data.flight_colours.map((c) => new THREE.Color(c));
const shot = decode(data.waypoints.shot, Uint8Array);
const heading = decode(data.waypoints.heading, Float32Array);
const pitch = decode(data.waypoints.pitch, Float32Array);
const pathPos = [];
const pathCol = [];
for (let i = 0; i + 1 < leg.length; i++) {
  if (flightOf[i] !== flightOf[i + 1]) continue;  // one flight lands, the next takes off
  pathPos.push(wp[3 * i], wp[3 * i + 1], wp[3 * i + 2], wp[3 * i + 3], wp[3 * i + 4], wp[3 * i + 5]);
  const col = FLIGHT_COLOURS.length > 1 ? FLIGHT_COLOURS[flightOf[i] - 1]
    : LEG_COLOURS[leg[i] === 0 ? 0 : (leg[i + 1] === 2 ? 2 : 1)];
  col.toArray(pathCol, pathCol.length);
  col.toArray(pathCol, pathCol.length);
}
const pathGeom = new THREE.BufferGeometry();
pathGeom.setAttribute('position', new THREE.Float32BufferAttribute(pathPos, 3));
pathGeom.setAttribute('color', new THREE.Float32BufferAttribute(pathCol, 3));
addLayer('path', new THREE.LineSegments(pathGeom, new THREE.LineBasicMaterial({ vertexColors: true })));

// Shots as small camera frusta (apex at the camera, base one frustum-depth ahead).
const fr = [];
const frLost = [];  // shots SfM could not register in the largest model (with a simulation)
const registered = data.simulation ? decode(data.simulation.shot_registered, Uint8Array) : null;
let shotNo = 0;
const tanH = Math.tan(data.camera.hfov_deg * Math.PI / 360);
const tanV = Math.tan(data.camera.vfov_deg * Math.PI / 360);
const depth = data.frustum_depth;
for (let i = 0; i < shot.length; i++) {
  if (!shot[i]) continue;
  const h = heading[i] * Math.PI / 180;
  const p = pitch[i] * Math.PI / 180;
  const f = new THREE.Vector3(Math.cos(p) * Math.sin(h), Math.cos(p) * Math.cos(h), Math.sin(p));
  const r = new THREE.Vector3(Math.cos(h), -Math.sin(h), 0);
  const u = new THREE.Vector3().crossVectors(r, f);
  const apex = new THREE.Vector3(wp[3 * i], wp[3 * i + 1], wp[3 * i + 2]);
  const corners = [[1, 1], [1, -1], [-1, -1], [-1, 1]].map(([a, b]) => apex.clone()
    .addScaledVector(f, depth).addScaledVector(r, a * depth * tanH).addScaledVector(u, b * depth * tanV));
  const out = registered && !registered[shotNo] ? frLost : fr;
  shotNo++;
  for (let k = 0; k < 4; k++) {
    out.push(...apex.toArray(), ...corners[k].toArray());
    out.push(...corners[k].toArray(), ...corners[(k + 1) % 4].toArray());
  }
}
const frGeom = new THREE.BufferGeometry();
frGeom.setAttribute('position', new THREE.Float32BufferAttribute(fr, 3));
const shotGroup = new THREE.Group();
shotGroup.add(new THREE.LineSegments(frGeom, new THREE.LineBasicMaterial({ color: 0x1a202c, transparent: true, opacity: 0.6 })));
if (frLost.length) {
  const lostGeom = new THREE.BufferGeometry();
  lostGeom.setAttribute('position', new THREE.Float32BufferAttribute(frLost, 3));
  shotGroup.add(new THREE.LineSegments(lostGeom, new THREE.LineBasicMaterial({ color: 0xe53e3e })));
}
addLayer('shots', shotGroup);

const start = new THREE.Mesh(new THREE.SphereGeometry(data.radius * 0.02, 16, 12),
  new THREE.MeshLambertMaterial({ color: 0x38a169 }));
start.position.set(wp[0], wp[1], wp[2]);
addLayer('start', start);

// Controls of the page.
for (const box of document.querySelectorAll('input[data-layer]')) {
  box.addEventListener('change', () => { layers[box.dataset.layer].visible = box.checked; render(); });
}
for (const radio of document.querySelectorAll('input[name=colour]')) {
  radio.addEventListener('change', () => { colourSamples(radio.value); render(); });
}

function resize() {
  const w = host.clientWidth;
  const h = host.clientHeight;
  renderer.setSize(w, h);
  camera.aspect = w / h;
  camera.updateProjectionMatrix();
  render();
}

function render() {
  renderer.render(scene, camera);
}

controls.addEventListener('change', render);
window.addEventListener('resize', resize);
resize();
window.reportReady = true;
