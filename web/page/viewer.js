// Mimic's browser viewer. A subscriber of the scene over a WebSocket (the server bridges it to
// its TCP protocol): the WebAssembly module (web/wasm/mimic_web.cpp, the C++ codec and realtime
// skin) takes the bytes, holds the body models and deforms each avatar at the LOD its distance
// calls for; this script draws with WebGL2, orbits the camera, enters WebXR (immersive-vr) with
// the avatars at true scale, and reports its own state into #stats.
'use strict';

const params = new URLSearchParams(location.search);
const canvas = document.getElementById('view');
const statusEl = document.getElementById('status');
const avatarsEl = document.getElementById('avatars');
const statsEl = document.getElementById('stats');
const vrButton = document.getElementById('vr');
const gl = canvas.getContext('webgl2', { antialias: true, xrCompatible: true, preserveDrawingBuffer: true });
const background = [0.125, 0.141, 0.165];

const report = { ok: false, connected: false, welcomed: false, avatars: 0, frames: 0, captures: [], lods: {},
                 deform_us: null, bytes_in: 0, model_bytes: 0, frame_bytes: 0, error: null };
function setStatus(text) { statusEl.textContent = text; }
function fail(text) { report.error = text; setStatus(text); statsEl.textContent = JSON.stringify(report); }

// ---- math (column-major 4x4, as WebGL and WebXR want) ----
function perspective(fovY, aspect, near, far) {
  const f = 1 / Math.tan(fovY / 2), nf = 1 / (near - far);
  return [f / aspect, 0, 0, 0, 0, f, 0, 0, 0, 0, (far + near) * nf, -1, 0, 0, 2 * far * near * nf, 0];
}
function lookAt(eye, at, up) {
  let zx = eye[0] - at[0], zy = eye[1] - at[1], zz = eye[2] - at[2];
  let l = Math.hypot(zx, zy, zz); zx /= l; zy /= l; zz /= l;
  let xx = up[1] * zz - up[2] * zy, xy = up[2] * zx - up[0] * zz, xz = up[0] * zy - up[1] * zx;
  l = Math.hypot(xx, xy, xz); xx /= l; xy /= l; xz /= l;
  const yx = zy * xz - zz * xy, yy = zz * xx - zx * xz, yz = zx * xy - zy * xx;
  return [xx, yx, zx, 0, xy, yy, zy, 0, xz, yz, zz, 0,
          -(xx * eye[0] + xy * eye[1] + xz * eye[2]), -(yx * eye[0] + yy * eye[1] + yz * eye[2]),
          -(zx * eye[0] + zy * eye[1] + zz * eye[2]), 1];
}
function multiply(a, b) {
  const o = new Array(16);
  for (let c = 0; c < 4; ++c)
    for (let r = 0; r < 4; ++r)
      o[c * 4 + r] = a[r] * b[c * 4] + a[4 + r] * b[c * 4 + 1] + a[8 + r] * b[c * 4 + 2] + a[12 + r] * b[c * 4 + 3];
  return o;
}
function translation(x, y, z) { return [1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, x, y, z, 1]; }

// ---- GL ----
function shader(type, src) {
  const s = gl.createShader(type); gl.shaderSource(s, src); gl.compileShader(s);
  if (!gl.getShaderParameter(s, gl.COMPILE_STATUS)) throw new Error(gl.getShaderInfoLog(s));
  return s;
}
function program(vs, fs) {
  const p = gl.createProgram();
  gl.attachShader(p, shader(gl.VERTEX_SHADER, vs)); gl.attachShader(p, shader(gl.FRAGMENT_SHADER, fs));
  gl.linkProgram(p);
  if (!gl.getProgramParameter(p, gl.LINK_STATUS)) throw new Error(gl.getProgramInfoLog(p));
  return p;
}
// Lit as `mimic view` lights its bodies (render/src/renderer.cpp): a key, a fill and a rim light
// fixed to the camera over a hemisphere ambient, on the colour each vertex carries.
const bodyProgram = program(`#version 300 es
  layout(location=0) in vec3 pos; layout(location=1) in vec3 nrm; layout(location=2) in vec3 alb;
  uniform mat4 view_proj, world; out vec3 n; out vec3 wp; out vec3 albedo;
  void main() {
    vec4 w = world * vec4(pos, 1.0); wp = w.xyz; n = mat3(world) * nrm; albedo = alb; gl_Position = view_proj * w;
  }`,
`#version 300 es
  precision mediump float; in vec3 n; in vec3 wp; in vec3 albedo; uniform vec3 eye; out vec4 frag;
  void main() {
    vec3 v = normalize(eye - wp), nn = normalize(n);
    if (dot(nn, v) < 0.0) nn = -nn;
    vec3 right = normalize(cross(vec3(0.0, 1.0, 0.0), v)), up = cross(v, right);
    vec3 key_dir = normalize(-0.35 * right + 0.55 * up + 0.75 * v);
    vec3 fill_dir = normalize(0.7 * right + 0.7 * v);
    vec3 rim_dir = normalize(0.45 * up - 0.9 * v);
    vec3 ambient = mix(vec3(0.25, 0.24, 0.24), vec3(0.42, 0.44, 0.48), 0.5 + 0.5 * nn.y);
    float key = max(dot(nn, key_dir), 0.0), fill = max(dot(nn, fill_dir), 0.0), ndv = max(dot(nn, v), 0.0);
    float rim = pow(1.0 - ndv, 2.5) * clamp(dot(nn, rim_dir) + 0.35, 0.0, 1.0);
    float spec = pow(max(dot(nn, normalize(key_dir + v)), 0.0), 36.0) * 0.07;
    vec3 light = ambient + vec3(1.0, 0.96, 0.90) * 0.66 * key + vec3(0.86, 0.92, 1.0) * 0.32 * fill;
    frag = vec4(albedo * light + vec3(spec) + vec3(0.95, 0.97, 1.0) * 0.30 * rim, 1.0);
  }`);
const lineProgram = program(`#version 300 es
  layout(location=0) in vec3 pos; uniform mat4 view_proj; void main() { gl_Position = view_proj * vec4(pos, 1.0); }`,
`#version 300 es
  precision mediump float; uniform vec3 colour; out vec4 frag; void main() { frag = vec4(colour, 1.0); }`);
const u = (p, n) => gl.getUniformLocation(p, n);
const bodyU = { view_proj: u(bodyProgram, 'view_proj'), world: u(bodyProgram, 'world'), eye: u(bodyProgram, 'eye') };
const lineU = { view_proj: u(lineProgram, 'view_proj'), colour: u(lineProgram, 'colour') };

// The floor: a 10 m grid of 1 m squares, X axis red, Z axis blue (as `mimic view`).
const grid = (() => {
  const v = [];
  for (let i = -5; i <= 5; ++i) v.push(i, 0, -5, i, 0, 5, -5, 0, i, 5, 0, i);
  const buf = gl.createBuffer(); gl.bindBuffer(gl.ARRAY_BUFFER, buf);
  gl.bufferData(gl.ARRAY_BUFFER, new Float32Array(v), gl.STATIC_DRAW);
  const axes = gl.createBuffer(); gl.bindBuffer(gl.ARRAY_BUFFER, axes);
  gl.bufferData(gl.ARRAY_BUFFER, new Float32Array([0, 0.002, 0, 1, 0.002, 0, 0, 0.002, 0, 0, 0.002, 1]), gl.STATIC_DRAW);
  return { buf, axes, count: v.length / 3 };
})();

// ---- the module, the socket ----
let M = null;           // the WebAssembly module
const meshes = new Map();  // "id/revision/lod" -> GL buffers of that avatar's LOD
const lodOf = new Map();   // avatar id -> LOD in use
let ws = null;

function flushOut() {
  const n = M._mw_out_size();
  if (n > 0 && ws && ws.readyState === 1) {
    ws.send(M.HEAPU8.slice(M._mw_out(), M._mw_out() + n));
    M._mw_out_clear();
  }
}

function connect() {
  M._mw_reset();
  ws = new WebSocket((location.protocol === 'https:' ? 'wss://' : 'ws://') + location.host + '/scene');
  ws.binaryType = 'arraybuffer';
  ws.onopen = () => { report.connected = true; M._mw_hello(params.get('lean') === '0' ? 0 : 1); flushOut(); };
  ws.onmessage = (e) => {
    const bytes = new Uint8Array(e.data);
    M.HEAPU8.set(bytes, M._mw_in(bytes.length));  // mw_in may grow memory: take HEAPU8 after it
    const err = M._mw_commit(bytes.length);
    if (err !== 0) { fail('the scene stream broke (code ' + err + ')'); ws.close(); return; }
    flushOut();
  };
  ws.onclose = () => {
    report.connected = false;
    if (M._mw_welcomed() < 0) { fail('refused: ' + M.UTF8ToString(M._mw_reject_message())); return; }
    setStatus('disconnected; retrying'); setTimeout(connect, 1000);
  };
}

function meshFor(id, lod) {
  const key = id + '/' + M._mw_revision(id) + '/' + lod;
  let m = meshes.get(key);
  if (m) return m;
  const vertices = M._mw_vertex_count(id, lod);
  if (!vertices) return null;
  const indexCount = M._mw_index_count(id, lod);
  const vao = gl.createVertexArray(); gl.bindVertexArray(vao);
  const pos = gl.createBuffer(); gl.bindBuffer(gl.ARRAY_BUFFER, pos);
  gl.bufferData(gl.ARRAY_BUFFER, vertices * 12, gl.DYNAMIC_DRAW);
  gl.enableVertexAttribArray(0); gl.vertexAttribPointer(0, 3, gl.FLOAT, false, 0, 0);
  const nrm = gl.createBuffer(); gl.bindBuffer(gl.ARRAY_BUFFER, nrm);
  gl.bufferData(gl.ARRAY_BUFFER, vertices * 12, gl.DYNAMIC_DRAW);
  gl.enableVertexAttribArray(1); gl.vertexAttribPointer(1, 3, gl.FLOAT, false, 0, 0);
  // The clothes' colours, a colour per vertex that blends across parts (no seams where they meet).
  const alb = gl.createBuffer(); gl.bindBuffer(gl.ARRAY_BUFFER, alb);
  gl.bufferData(gl.ARRAY_BUFFER, M.HEAPF32.subarray(M._mw_albedo(id, lod) >> 2, (M._mw_albedo(id, lod) >> 2) + vertices * 3), gl.STATIC_DRAW);
  gl.enableVertexAttribArray(2); gl.vertexAttribPointer(2, 3, gl.FLOAT, false, 0, 0);
  const idx = gl.createBuffer(); gl.bindBuffer(gl.ELEMENT_ARRAY_BUFFER, idx);
  gl.bufferData(gl.ELEMENT_ARRAY_BUFFER, M.HEAPU32.subarray(M._mw_indices(id, lod) >> 2, (M._mw_indices(id, lod) >> 2) + indexCount), gl.STATIC_DRAW);
  gl.bindVertexArray(null);
  const parts = [];
  for (let p = 0; p < M._mw_part_count(id, lod); ++p)
    parts.push({ first: M._mw_part_first(id, lod, p), count: M._mw_part_triangles(id, lod, p) });
  m = { vao, pos, nrm, vertices, triangles: indexCount / 3, parts };
  meshes.set(key, m);
  return m;
}

// ---- camera: orbit around a target that follows the avatars ----
const cam = { yaw: 0.5, pitch: 0.25, dist: 5, target: [0, 0.9, 0], pan: [0, 0, 0], fovY: 50 * Math.PI / 180 };
let drag = null;
canvas.addEventListener('pointerdown', (e) => { drag = { x: e.clientX, y: e.clientY, pan: e.button !== 0 }; canvas.setPointerCapture(e.pointerId); });
canvas.addEventListener('pointerup', () => { drag = null; });
canvas.addEventListener('contextmenu', (e) => e.preventDefault());
canvas.addEventListener('pointermove', (e) => {
  if (!drag) return;
  const dx = e.clientX - drag.x, dy = e.clientY - drag.y; drag.x = e.clientX; drag.y = e.clientY;
  if (drag.pan) {
    const s = cam.dist * 0.0015;
    cam.pan[0] -= (Math.cos(cam.yaw) * dx) * s; cam.pan[2] += (Math.sin(cam.yaw) * dx) * s; cam.pan[1] += dy * s;
  } else {
    cam.yaw -= dx * 0.008; cam.pitch = Math.max(-0.2, Math.min(1.4, cam.pitch + dy * 0.008));
  }
});
canvas.addEventListener('wheel', (e) => { e.preventDefault(); cam.dist = Math.max(0.8, Math.min(40, cam.dist * Math.exp(e.deltaY * 0.001))); }, { passive: false });

function eye() {
  const t = [cam.target[0] + cam.pan[0], cam.target[1] + cam.pan[1], cam.target[2] + cam.pan[2]];
  return { t, e: [t[0] + cam.dist * Math.cos(cam.pitch) * Math.sin(cam.yaw), t[1] + cam.dist * Math.sin(cam.pitch),
                  t[2] + cam.dist * Math.cos(cam.pitch) * Math.cos(cam.yaw)] };
}

// ---- a frame ----
let deformUs = 0, deformCount = 0;
function deformAll(eyePos, viewportHeight, fovY) {
  const n = M._mw_avatar_count(), shown = [];
  for (let i = 0; i < n; ++i) {
    const id = M._mw_avatar_id(i);
    const root = [M._mw_root(id, 0), M._mw_root(id, 1), M._mw_root(id, 2)];
    const dist = Math.hypot(root[0] - eyePos[0], root[1] - eyePos[1], root[2] - eyePos[2]);
    const lod = M._mw_choose_lod(dist, lodOf.has(id) ? lodOf.get(id) : -1, viewportHeight, fovY, M._mw_height(id));
    lodOf.set(id, lod);
    const m = meshFor(id, lod);
    if (!m) continue;
    const t0 = performance.now();
    const p = M._mw_deform(id, lod) >> 2, q = M._mw_normals(id, lod) >> 2;
    deformUs += (performance.now() - t0) * 1000; deformCount++;
    gl.bindBuffer(gl.ARRAY_BUFFER, m.pos); gl.bufferSubData(gl.ARRAY_BUFFER, 0, M.HEAPF32, p, m.vertices * 3);
    gl.bindBuffer(gl.ARRAY_BUFFER, m.nrm); gl.bufferSubData(gl.ARRAY_BUFFER, 0, M.HEAPF32, q, m.vertices * 3);
    shown.push({ id, lod, m, root, dist });
  }
  return shown;
}

function drawScene(viewProj, shown, world, eyePos) {
  gl.useProgram(lineProgram);
  gl.uniformMatrix4fv(lineU.view_proj, false, multiply(viewProj, world));
  gl.enableVertexAttribArray(0);
  gl.bindBuffer(gl.ARRAY_BUFFER, grid.buf); gl.vertexAttribPointer(0, 3, gl.FLOAT, false, 0, 0);
  gl.uniform3f(lineU.colour, 0.36, 0.38, 0.42); gl.drawArrays(gl.LINES, 0, grid.count);
  gl.bindBuffer(gl.ARRAY_BUFFER, grid.axes); gl.vertexAttribPointer(0, 3, gl.FLOAT, false, 0, 0);
  gl.uniform3f(lineU.colour, 0.8, 0.2, 0.2); gl.drawArrays(gl.LINES, 0, 2);
  gl.uniform3f(lineU.colour, 0.25, 0.35, 0.9); gl.drawArrays(gl.LINES, 2, 2);
  gl.useProgram(bodyProgram);
  gl.uniformMatrix4fv(bodyU.view_proj, false, viewProj);
  gl.uniformMatrix4fv(bodyU.world, false, world);
  gl.uniform3fv(bodyU.eye, eyePos);
  for (const s of shown) {
    gl.bindVertexArray(s.m.vao);
    for (const p of s.m.parts) {
      gl.drawElements(gl.TRIANGLES, p.count * 3, gl.UNSIGNED_INT, p.first * 12);
    }
  }
  gl.bindVertexArray(null);
}

// What the page shows, read back from its own canvas: the share of pixels that are not the
// background, and a checksum of them (two captures a second apart differ while avatars move).
function capture() {
  const w = gl.drawingBufferWidth, h = gl.drawingBufferHeight, px = new Uint8Array(w * h * 4);
  gl.readPixels(0, 0, w, h, gl.RGBA, gl.UNSIGNED_BYTE, px);
  const bg = background.map((c) => Math.round(c * 255));
  let covered = 0, sum = 0;
  for (let i = 0; i < px.length; i += 4) {
    // Body pixels: far from the background and from the grey grid lines (saturated or bright).
    const r = px[i], g = px[i + 1], b = px[i + 2];
    const off = Math.abs(r - bg[0]) + Math.abs(g - bg[1]) + Math.abs(b - bg[2]);
    const grey = Math.max(r, g, b) - Math.min(r, g, b) < 12 && r < 110;
    if (off > 40 && !grey) covered++;
    sum = (sum * 31 + r + 7 * g + 13 * b) >>> 0;
  }
  return { t_ms: Math.round(performance.now()), avatars: drawnAvatars, coverage: covered / (w * h), checksum: sum, width: w, height: h };
}

let lastCapture = 0, lastReport = 0, drawnAvatars = 0, fittedFor = 0;

// End-to-end latency: a pose's capture time (the publisher's wall clock, µs since the epoch, in
// every frame on the wire) to this page having deformed that pose and submitted its draw calls
// (the clock stops when drawScene returns; the GPU's work and the compositor come after). The
// page's wall clock is performance.timeOrigin + now(): the figure means something only when page
// and publisher share a clock (the same machine). Each pose counts once, when first drawn.
const latency = { ms: new Float64Array(4096), n: 0, drawn: new Map() };
function noteDrawn(shown) {
  const nowUs = (performance.timeOrigin + performance.now()) * 1000;
  for (const s of shown) {
    const t = M._mw_time_us(s.id);
    if (!t || latency.drawn.get(s.id) === t) continue;
    latency.drawn.set(s.id, t);
    latency.ms[latency.n++ % latency.ms.length] = (nowUs - t) / 1000;
  }
}
function latencySummary() {
  const n = Math.min(latency.n, latency.ms.length);
  if (!n) return null;
  const v = Array.from(latency.ms.subarray(0, n)).sort((a, b) => a - b);
  const at = (q) => +v[Math.min(n - 1, Math.floor(q * n))].toFixed(2);
  return { poses: latency.n, p50_ms: at(0.5), p99_ms: at(0.99), max_ms: +v[n - 1].toFixed(2) };
}
function frame(now) {
  const w = canvas.clientWidth * devicePixelRatio, h = canvas.clientHeight * devicePixelRatio;
  if (canvas.width !== w || canvas.height !== h) { canvas.width = w; canvas.height = h; }
  gl.viewport(0, 0, canvas.width, canvas.height);
  gl.clearColor(...background, 1); gl.clear(gl.COLOR_BUFFER_BIT | gl.DEPTH_BUFFER_BIT);
  gl.enable(gl.DEPTH_TEST);
  if (M) {
    const n = M._mw_avatar_count();
    // Follow the avatars' centre on the floor (glides; panning by hand adds to it).
    if (n > 0) {
      let cx = 0, cz = 0, maxd = 0;
      for (let i = 0; i < n; ++i) { const id = M._mw_avatar_id(i); cx += M._mw_root(id, 0); cz += M._mw_root(id, 2); }
      cx /= n; cz /= n;
      for (let i = 0; i < n; ++i) { const id = M._mw_avatar_id(i); maxd = Math.max(maxd, Math.hypot(M._mw_root(id, 0) - cx, M._mw_root(id, 2) - cz)); }
      cam.target[0] += (cx - cam.target[0]) * 0.05; cam.target[2] += (cz - cam.target[2]) * 0.05;
      // Fitted to the scene once the avatars have poses, and again when one joins or leaves.
      if (fittedFor !== n && M._mw_has_pose(M._mw_avatar_id(n - 1))) {
        cam.dist = Math.max(4, 2.2 * maxd + 3.5); cam.target = [cx, 0.9, cz]; fittedFor = n;
      }
    }
    const { t, e } = eye();
    const viewProj = multiply(perspective(cam.fovY, canvas.width / canvas.height, 0.05, 100), lookAt(e, t, [0, 1, 0]));
    const shown = deformAll(e, canvas.height, cam.fovY);
    drawScene(viewProj, shown, translation(0, 0, 0), e);
    drawnAvatars = shown.length;
    noteDrawn(shown);
    const tNow = performance.now();
    if (tNow - lastCapture > 500 && shown.length) {
      lastCapture = tNow;
      report.captures.push(capture());
      if (report.captures.length > 8) report.captures.shift();
    }
    if (now - lastReport > 250) { lastReport = now; updateReport(shown); }
  }
  if (!xrSession) requestAnimationFrame(frame);
}

function updateReport(shown) {
  report.ok = true;
  report.welcomed = M._mw_welcomed() > 0;
  report.avatars = M._mw_avatar_count();
  report.frames = M._mw_counter(1);
  report.lean_keys = M._mw_counter(2);
  report.model_bytes = M._mw_counter(8);
  report.frame_bytes = M._mw_counter(9);
  report.bytes_in = M._mw_counter(10);
  report.lods = {};
  for (const s of shown) report.lods[s.id] = { lod: s.lod, triangles: s.m.triangles, distance_m: +s.dist.toFixed(2) };
  report.latency = latencySummary();
  if (deformCount) { report.deform_us = +(deformUs / deformCount).toFixed(1); deformUs = 0; deformCount = 0; }
  statsEl.textContent = JSON.stringify(report);
  setStatus(report.welcomed ? `${report.avatars} avatar(s), ${report.frames} frames` : 'connecting…');
  avatarsEl.textContent = shown.map((s) => `#${s.id}: LOD ${s.lod}, ${s.m.triangles} triangles, ${s.dist.toFixed(1)} m`).join(' · ');
  if (params.get('bench') && !report.bench && shown.length) runBench(shown[0].id);
}

// The deform alone per LOD (microseconds a frame), measured here in WebAssembly: the median of
// nine batches of 50 frames (the machine may be busy; the browser's timer is coarse).
function runBench(id) {
  report.bench = { avatar: id, deform_us: [] };
  for (let lod = 0; lod < M._mw_lod_count(); ++lod) {
    M._mw_bench_deform(id, lod, 5);  // builds the LOD and warms up
    const batches = [];
    for (let b = 0; b < 9; ++b) batches.push(M._mw_bench_deform(id, lod, 50));
    batches.sort((a, b) => a - b);
    report.bench.deform_us.push(+batches[4].toFixed(1));
  }
}

// ---- WebXR: the avatars at true scale, their centre 2 m ahead of the user ----
let xrSession = null;
async function setupXR() {
  if (!navigator.xr || !(await navigator.xr.isSessionSupported('immersive-vr').catch(() => false))) {
    vrButton.textContent = 'VR not available'; return;
  }
  vrButton.disabled = false;
  vrButton.onclick = async () => {
    if (xrSession) { xrSession.end(); return; }
    const session = await navigator.xr.requestSession('immersive-vr', { optionalFeatures: ['local-floor'] });
    xrSession = session; vrButton.textContent = 'Exit VR';
    await gl.makeXRCompatible();
    session.updateRenderState({ baseLayer: new XRWebGLLayer(session, gl) });
    const space = await session.requestReferenceSpace('local-floor').catch(() => session.requestReferenceSpace('local'));
    session.addEventListener('end', () => { xrSession = null; vrButton.textContent = 'Enter VR'; requestAnimationFrame(frame); });
    const xrFrame = (t, xf) => {
      session.requestAnimationFrame(xrFrame);
      const pose = xf.getViewerPose(space);
      if (!pose || !M) return;
      const layer = session.renderState.baseLayer;
      gl.bindFramebuffer(gl.FRAMEBUFFER, layer.framebuffer);
      gl.clearColor(...background, 1); gl.clear(gl.COLOR_BUFFER_BIT | gl.DEPTH_BUFFER_BIT); gl.enable(gl.DEPTH_TEST);
      // The scene is moved (not scaled: metres stay metres) so its centre stands 2 m ahead of
      // the user; the LOD distance is measured from the head in the scene's own coordinates.
      const offset = [-cam.target[0], 0, -cam.target[2] - 2];
      const head = pose.transform.position;
      const headInScene = [head.x - offset[0], head.y - offset[1], head.z - offset[2]];
      const shown = deformAll(headInScene, layer.framebufferHeight, Math.PI / 2);
      const world = translation(...offset);
      for (const view of pose.views) {
        const vp = layer.getViewport(view);
        gl.viewport(vp.x, vp.y, vp.width, vp.height);
        const p = view.transform.position;
        drawScene(multiply(Array.from(view.projectionMatrix), Array.from(view.transform.inverse.matrix)), shown, world, [p.x, p.y, p.z]);
      }
    };
    session.requestAnimationFrame(xrFrame);
  };
}

// ---- start ----
if (!gl) {
  fail('this browser has no WebGL2');
} else if (typeof createMimicWebScript === 'undefined') {
  const s = document.createElement('script');
  s.src = 'mimic_web.js';
  s.onerror = () => fail('this Mimic was built without Emscripten: the WebAssembly skin is missing (see docs/browser.md)');
  s.onload = () => createMimicWeb().then((mod) => {
    M = mod; setStatus('connecting…'); connect(); setupXR(); requestAnimationFrame(frame);
  }, (e) => fail('the WebAssembly skin failed to load: ' + e));
  document.head.appendChild(s);
}
