// patina view: one page for any patina output folder (see view.rs).
'use strict';

const $ = (id) => document.getElementById(id);
const el = (tag, props = {}, ...children) => {
  const e = Object.assign(document.createElement(tag), props);
  children.forEach((c) => e.append(c));
  return e;
};
const fileUrl = (p) => '/files/' + p.split('/').map(encodeURIComponent).join('/');
const isImage = (p) => /\.(png|jpe?g|gif)$/i.test(p);
const SELFTEST = new URLSearchParams(location.search).has('selftest');
const loaded = (img) => (img.complete && img.naturalWidth > 0 ? Promise.resolve() : new Promise((ok) => { img.onload = ok; img.onerror = ok; }));

// ---- Zoom and pan of the stage --------------------------------------------

const view = { mode: 'fit', scale: 1, x: 0, y: 0, contentW: 1, contentH: 1 };

function applyTransform() {
  const c = $('canvas');
  c.style.transform = `translate(${view.x}px, ${view.y}px) scale(${view.scale})`;
  c.classList.toggle('pixelated', view.scale >= 2);
}

function setZoom(mode) {
  view.mode = mode;
  const vp = $('viewport').getBoundingClientRect();
  if (mode === 'fit') {
    view.scale = Math.min(vp.width / view.contentW, vp.height / view.contentH, 8) || 1;
  } else {
    view.scale = mode;
  }
  view.x = (vp.width - view.contentW * view.scale) / 2;
  view.y = Math.max(0, (vp.height - view.contentH * view.scale) / 2);
  applyTransform();
  document.querySelectorAll('button[data-zoom]').forEach((b) => b.classList.toggle('on', String(mode) === b.dataset.zoom));
}

function zoomButtons() {
  return el('span', {}, ...[['fit', 'Fit'], ['1', '1:1'], ['2', '2:1']].map(([z, label]) => {
    const b = el('button', { textContent: label });
    b.dataset.zoom = z;
    b.onclick = () => setZoom(z === 'fit' ? 'fit' : Number(z));
    return b;
  }));
}

function enablePan() {
  const vp = $('viewport');
  let drag = null;
  vp.addEventListener('mousedown', (e) => { drag = { x: e.clientX - view.x, y: e.clientY - view.y }; vp.classList.add('dragging'); });
  window.addEventListener('mouseup', () => { drag = null; vp.classList.remove('dragging'); });
  window.addEventListener('mousemove', (e) => {
    if (!drag) return;
    view.x = e.clientX - drag.x;
    view.y = e.clientY - drag.y;
    applyTransform();
  });
  window.addEventListener('resize', () => { if (view.mode === 'fit') setZoom('fit'); });
}

function setContentSize(w, h) {
  view.contentW = Math.max(1, w);
  view.contentH = Math.max(1, h);
  setZoom(view.mode);
}

// ---- Side panels ---------------------------------------------------------------

function imagePanel(path, onPick) {
  const p = el('div', { className: 'panel' }, el('img', { src: fileUrl(path), loading: 'lazy', alt: path }), el('span', { textContent: path }));
  p.onclick = () => {
    document.querySelectorAll('.panel').forEach((q) => q.classList.remove('active'));
    p.classList.add('active');
    onPick(path);
  };
  return p;
}

function showParams(manifest, extra) {
  const shown = manifest ? { command: manifest.command, seed: manifest.seed, inputs: manifest.inputs, params: manifest.params, metrics: manifest.metrics, timings_ms: manifest.timings_ms } : {};
  $('params').textContent = JSON.stringify(Object.assign(shown, extra || {}), null, 2);
}

// ---- Sequences -----------------------------------------------------------------

/// Frames grouped into tracks by their path with the digits taken out
/// (frames/003_plane.png and frames/003_sphere.png are two tracks).
function tracksOf(frames) {
  const tracks = new Map();
  for (const f of frames) {
    const key = f.path.replace(/\d+/g, '#');
    if (!tracks.has(key)) tracks.set(key, []);
    tracks.get(key).push(f);
  }
  for (const list of tracks.values()) list.sort((a, b) => a.t - b.t);
  return [...tracks.entries()];
}

async function sequenceView(listing) {
  const m = listing.manifest;
  $('what').textContent = `${m.command}: ${m.frames.length} frames`;
  const tracks = tracksOf(m.frames);
  // Numbered images beside the frames (a render's per-t maps) become
  // tracks too, at the frames' times.
  const times = tracks[0][1].map((f) => f.t);
  const known = new Set(m.frames.map((f) => f.path));
  const extra = new Map();
  for (const p of listing.files.filter((q) => isImage(q) && !known.has(q) && /\d/.test(q))) {
    const key = p.replace(/\d+/g, '#');
    if (!extra.has(key)) extra.set(key, []);
    extra.get(key).push(p);
  }
  for (const [key, paths] of extra) {
    if (paths.length === times.length && paths.length > 1) {
      paths.sort();
      tracks.push([key, paths.map((path, i) => ({ t: times[i], path }))]);
    }
  }
  let track = tracks[0][1];
  const frameSet = new Set(tracks.flatMap(([, list]) => list.map((f) => f.path)));

  const main = el('img', { id: 'frame', alt: 'frame' });
  const before = el('img', { id: 'before', className: 'layer', alt: 'before' });
  const line = el('div', { id: 'wipe-line' });
  const holder = el('div', { style: 'position: relative' }, main, before, line);
  $('canvas').append(holder);

  const slider = el('input', { type: 'range', id: 'time', min: 0, max: track.length - 1, step: 1, value: 0 });
  const label = el('span', { id: 'time-label' });
  const play = el('button', { textContent: 'Play', id: 'play' });
  const wipeOn = el('input', { type: 'checkbox', id: 'wipe-on', title: 'left of the line: the input; right: the current frame' });
  const wipe = el('input', { type: 'range', id: 'wipe', min: 0, max: 100, value: 50 });
  const trackSelect = el('select', { id: 'track' }, ...tracks.map(([key], i) => el('option', { value: i, textContent: key })));

  const showFrame = (i) => {
    const f = track[i];
    main.src = fileUrl(f.path);
    label.textContent = `t = ${Number(f.t).toFixed(3)}  (${i + 1}/${track.length})`;
  };
  // The wipe compares with the input: weathering's input is the frame at
  // t = 1 (its own age); the other jobs start from it at their first frame.
  const reference = () => {
    if (/^weather/.test(m.command)) {
      const input = track.find((f) => Math.abs(f.t - 1) < 1e-6);
      if (input) return input;
    }
    return track[0];
  };
  const updateWipe = () => {
    before.hidden = !wipeOn.checked;
    line.hidden = !wipeOn.checked;
    before.src = fileUrl(reference().path);
    const x = Number(wipe.value);
    before.style.clipPath = `inset(0 ${100 - x}% 0 0)`;
    line.style.left = `${x}%`;
  };
  slider.addEventListener('input', () => showFrame(Number(slider.value)));
  wipe.addEventListener('input', updateWipe);
  wipeOn.addEventListener('change', updateWipe);
  trackSelect.addEventListener('change', () => {
    track = tracks[Number(trackSelect.value)][1];
    slider.max = track.length - 1;
    slider.value = Math.min(Number(slider.value), track.length - 1);
    showFrame(Number(slider.value));
    updateWipe();
  });
  let timer = null;
  play.onclick = () => {
    if (timer) { clearInterval(timer); timer = null; play.textContent = 'Play'; return; }
    play.textContent = 'Pause';
    timer = setInterval(() => { slider.value = (Number(slider.value) + 1) % track.length; showFrame(Number(slider.value)); }, 150);
  };
  main.addEventListener('load', () => setContentSize(main.naturalWidth, main.naturalHeight));

  const controls = [play, el('label', {}, 'time', slider), label, el('label', {}, wipeOn, 'before/after'), wipe, zoomButtons()];
  if (tracks.length > 1) controls.splice(0, 0, el('label', {}, 'track', trackSelect));
  $('controls').append(...controls);

  // Everything else the folder holds: age map, intact, degree, tendency, masks, the GIF.
  const others = listing.files.filter((p) => isImage(p) && !frameSet.has(p));
  for (const p of others) {
    $('panels').append(imagePanel(p, (path) => {
      main.src = fileUrl(path);
      label.textContent = path;
    }));
  }
  showParams(m, { tracks: tracks.map(([k, l]) => `${k} (${l.length})`) });
  // A link can open at a frame and with the wipe on: ?frame=N&wipe=PERCENT.
  const query = new URLSearchParams(location.search);
  if (query.has('frame')) slider.value = Math.min(track.length - 1, Math.max(0, Number(query.get('frame')) || 0));
  if (query.has('wipe')) { wipeOn.checked = true; wipe.value = Number(query.get('wipe')) || 50; }
  showFrame(Number(slider.value));
  updateWipe();
  await loaded(main);

  if (SELFTEST) {
    const result = { view: 'sequence', slider: !!$('time'), frames: track.length };
    const first = main.src;
    slider.value = track.length - 1;
    slider.dispatchEvent(new Event('input'));
    await loaded(main);
    result.frameChanged = main.src !== first && main.naturalWidth > 0;
    return result;
  }
  return null;
}

// ---- Synthesis -----------------------------------------------------------------

async function galleryView(listing) {
  const m = listing.manifest;
  $('what').textContent = m ? m.command : 'folder';
  // This folder's own images; subfolders (a demo's jobs) are views of their own.
  const images = listing.files.filter((p) => isImage(p) && !p.includes('/'));
  const exemplar = images.filter((p) => /exemplar|input|source/i.test(p.split('/').pop()));
  const outputs = images.filter((p) => !exemplar.includes(p));
  const ordered = [...exemplar, ...outputs];
  const row = el('div', { className: 'row' });
  const coords = ordered.filter((p) => /coord|nnf|source_map/i.test(p));
  for (const p of ordered.filter((q) => !coords.includes(q))) {
    const img = el('img', { src: fileUrl(p), alt: p });
    row.append(el('figure', {}, img, el('figcaption', { textContent: p })));
  }
  $('canvas').append(row);
  const overlay = el('input', { type: 'range', min: 0, max: 100, value: 0, id: 'overlay' });
  const controls = [zoomButtons()];
  if (coords.length) {
    // The source-coordinate map over the first output, with an opacity slider.
    const fig = row.children[exemplar.length] || row.children[0];
    const map = el('img', { src: fileUrl(coords[0]), className: 'layer', style: 'opacity: 0; top: 0; left: 0' });
    fig.style.position = 'relative';
    fig.append(map);
    overlay.addEventListener('input', () => { map.style.opacity = Number(overlay.value) / 100; });
    controls.unshift(el('label', {}, 'source-coordinate map', overlay));
  }
  const folders = [...new Set(listing.files.filter((p) => p.includes('/')).map((p) => p.split('/')[0]))];
  if (folders.length) controls.push(el('span', { textContent: `subfolders (patina view each): ${folders.join(', ')}` }));
  $('controls').append(...controls);
  for (const p of images) $('panels').append(imagePanel(p, () => {}));
  showParams(m);
  await Promise.all([...row.querySelectorAll('img')].map(loaded));
  setContentSize(row.scrollWidth, row.scrollHeight);
  return SELFTEST ? { view: 'gallery', images: images.length } : null;
}

// ---- Materials (WebGL2) ----------------------------------------------------------

const SHADE_GLSL = `
const float PI = 3.14159265;
// Khronos PBR Neutral without its toe, as render.rs.
vec3 neutral(vec3 c) {
  c = max(c, 0.0);
  float peak = max(c.r, max(c.g, c.b));
  const float start = 0.76;
  if (peak < start) return clamp(c, 0.0, 1.0);
  float d = 1.0 - start;
  float newPeak = 1.0 - d * d / (peak + d - start);
  c *= newPeak / peak;
  float g = 1.0 - 1.0 / (0.15 * (peak - newPeak) + 1.0);
  return clamp(mix(c, vec3(newPeak), g), 0.0, 1.0);
}
vec3 toSrgb(vec3 v) { return mix(v * 12.92, 1.055 * pow(v, vec3(1.0 / 2.4)) - 0.055, step(vec3(0.0031308), v)); }
vec3 fromSrgb(vec3 v) { v = clamp(v, 0.0, 1.0); return mix(v / 12.92, pow((v + 0.055) / 1.055, vec3(2.4)), step(vec3(0.04045), v)); }
// The previews' sun with a sky fill (render.rs: SKY_*, sky_irradiance, ambient 0.25).
vec3 skyIrradiance(vec3 n) {
  float seeSky = 0.5 * (1.0 + n.y);
  vec3 sky = vec3(2.05, 2.0, 1.95) + (vec3(1.25, 1.35, 1.55) - vec3(2.05, 2.0, 1.95)) * (2.0 / 3.0);
  return seeSky * sky + (1.0 - seeSky) * vec3(0.55, 0.5, 0.45);
}
vec3 shade(vec3 kd, vec3 ks, float rough, vec3 n) {
  vec3 l = normalize(vec3(0.45, 0.55, 0.70)), v = vec3(0.0, 0.0, 1.0), h = normalize(l + v);
  float nl = dot(n, l), nv = max(dot(n, v), 1e-4), nh = max(dot(n, h), 0.0), vh = max(dot(v, h), 0.0);
  vec3 outc = 0.25 * kd * skyIrradiance(n);
  if (nl <= 0.0) return outc;
  float a = clamp(rough * rough, 1e-4, 1.0), a2 = a * a;
  float d = a2 / (PI * pow(nh * nh * (a2 - 1.0) + 1.0, 2.0));
  float g1l = 2.0 * nl / (nl + sqrt(a2 + (1.0 - a2) * nl * nl));
  float g1v = 2.0 * nv / (nv + sqrt(a2 + (1.0 - a2) * nv * nv));
  vec3 f = ks + (1.0 - ks) * pow(1.0 - vh, 5.0);
  vec3 spec = d * g1l * g1v * f / (4.0 * nl * nv);
  return outc + PI * (kd / PI + spec) * nl;
}`;

function identOf(name) {
  const s = name.toLowerCase().replace(/[^a-z0-9]/g, '');
  return /^[a-z]/.test(s) ? s : 'p' + s;
}

function fragmentSource(meta) {
  const m = meta.degree + 1;
  let decl = '';
  let evalCode = '';
  for (const p of meta.params) {
    const id = identOf(p.name);
    const sw = p.channels === 1 ? '.r' : '.rgb';
    const ty = p.channels === 1 ? 'float' : 'vec3';
    for (let k = 0; k < m; k++) decl += `uniform sampler2D ${id}_${k};\n`;
    evalCode += `  ${ty} ${id} = texture(${id}_${m - 1}, st)${sw};\n`;
    for (let k = m - 2; k >= 0; k--) evalCode += `  ${id} = ${id} * t + texture(${id}_${k}, st)${sw};\n`;
  }
  const has = (n) => meta.params.find((p) => p.name.toLowerCase() === n);
  const srgb = meta.encoding === 'srgb';
  const colour = (n, def) => {
    const p = has(n);
    if (!p) return def;
    const v = p.channels === 1 ? `vec3(${n})` : n;
    return srgb ? `fromSrgb(${v})` : `max(${v}, 0.0)`;
  };
  return `#version 300 es
precision highp float;
precision highp sampler2D;
${decl}
uniform float t;
uniform int mode;
uniform vec2 viewport;
in vec2 uv;
out vec4 colour;
${SHADE_GLSL}
void main() {
  vec2 tc = uv;
  vec3 ngeo = vec3(0.0, 0.0, 1.0), tangent = vec3(1.0, 0.0, 0.0), bitangent = vec3(0.0, 1.0, 0.0);
  if (mode == 1) {
    vec2 p = uv * 2.0 - 1.0;
    float z2 = 1.0 - dot(p, p);
    if (z2 <= 0.0) { colour = vec4(vec3(0.12), 1.0); return; }
    ngeo = vec3(p, sqrt(z2));
    tc = vec2(atan(ngeo.x, ngeo.z) / PI + 0.5, asin(clamp(ngeo.y, -1.0, 1.0)) / PI + 0.5);
    tangent = normalize(vec3(ngeo.z, 0.0, -ngeo.x));
    bitangent = cross(ngeo, tangent);
  }
  vec2 st = vec2(tc.x, 1.0 - tc.y);
${evalCode}
  vec3 kd = ${colour('diffuse', 'vec3(0.5)')};
  vec3 ks = ${colour('specular', 'vec3(0.04)')};
  float rough = ${has('roughness') ? 'clamp(roughness, 0.0, 1.0)' : '0.8'};
  vec3 nt = ${has('normal') && has('normal').channels === 3 ? `normalize((normal * 2.0 - 1.0) * vec3(1.0, ${meta.normal_green_down ? '-1.0' : '1.0'}, 1.0))` : 'vec3(0.0, 0.0, 1.0)'};
  vec3 n = normalize(nt.x * tangent + nt.y * bitangent + nt.z * ngeo);
  colour = vec4(toSrgb(neutral(shade(kd, ks, rough, n))), 1.0);
}`;
}

const VERTEX = `#version 300 es
in vec2 pos;
out vec2 uv;
void main() { uv = pos * 0.5 + 0.5; gl_Position = vec4(pos, 0.0, 1.0); }`;

function compile(gl, type, src) {
  const s = gl.createShader(type);
  gl.shaderSource(s, src);
  gl.compileShader(s);
  if (!gl.getShaderParameter(s, gl.COMPILE_STATUS)) throw new Error(gl.getShaderInfoLog(s));
  return s;
}

/// The material's maps at time t, evaluated on the CPU, as 2D canvases.
function mapCanvases(meta, data, t) {
  const { width: w, height: h } = meta;
  const m = meta.degree + 1;
  const total = meta.params.reduce((a, p) => a + p.channels, 0) * m;
  const out = [];
  let c0 = 0;
  for (const p of meta.params) {
    const canvas = el('canvas', { width: w, height: h });
    const ctx = canvas.getContext('2d');
    const img = ctx.createImageData(w, h);
    const linearColour = meta.encoding === 'linear' && ['diffuse', 'specular'].includes(p.name.toLowerCase());
    for (let i = 0; i < w * h; i++) {
      for (let k = 0; k < 3; k++) {
        const c = c0 + Math.min(k, p.channels - 1);
        let v = 0;
        for (let j = m - 1; j >= 0; j--) v = v * t + data[i * total + c * m + j];
        v = Math.min(1, Math.max(0, v));
        if (linearColour) v = v <= 0.0031308 ? v * 12.92 : 1.055 * Math.pow(v, 1 / 2.4) - 0.055;
        img.data[i * 4 + k] = Math.round(v * 255);
      }
      img.data[i * 4 + 3] = 255;
    }
    ctx.putImageData(img, 0, 0);
    out.push([p.name, canvas]);
    c0 += p.channels;
  }
  return out;
}

async function materialView(listing) {
  const meta = await (await fetch('/api/material.json')).json();
  const data = new Float32Array(await (await fetch('/api/material.bin')).arrayBuffer());
  $('what').textContent = `material ${meta.width}x${meta.height}, degree ${meta.degree}, ${meta.params.map((p) => p.name).join(', ')}`;
  const side = 384;
  const canvas = el('canvas', { width: 2 * side, height: side, id: 'gl', className: 'gl' });
  $('canvas').append(canvas);
  const gl = canvas.getContext('webgl2', { preserveDrawingBuffer: true, antialias: true });
  const slider = el('input', { type: 'range', id: 'time', min: 0, max: 1, step: 0.01, value: 0 });
  const label = el('span', { id: 'time-label', textContent: 't = 0.00' });
  const play = el('button', { textContent: 'Play', id: 'play' });
  $('controls').append(play, el('label', {}, 'time', slider), label, zoomButtons());
  showParams(listing.manifest, { material: meta });
  if (!gl) {
    $('what').textContent += ' (WebGL2 is not available in this browser)';
    return SELFTEST ? { view: 'material', slider: true, webgl: false } : null;
  }
  const prog = gl.createProgram();
  gl.attachShader(prog, compile(gl, gl.VERTEX_SHADER, VERTEX));
  gl.attachShader(prog, compile(gl, gl.FRAGMENT_SHADER, fragmentSource(meta)));
  gl.linkProgram(prog);
  if (!gl.getProgramParameter(prog, gl.LINK_STATUS)) throw new Error(gl.getProgramInfoLog(prog));
  gl.useProgram(prog);
  const buf = gl.createBuffer();
  gl.bindBuffer(gl.ARRAY_BUFFER, buf);
  gl.bufferData(gl.ARRAY_BUFFER, new Float32Array([-1, -1, 1, -1, -1, 1, 1, 1]), gl.STATIC_DRAW);
  const loc = gl.getAttribLocation(prog, 'pos');
  gl.enableVertexAttribArray(loc);
  gl.vertexAttribPointer(loc, 2, gl.FLOAT, false, 0, 0);
  // One RGBA32F texture per parameter and coefficient. With float
  // filtering, mip levels are built here (2x2 means; evaluation is linear,
  // so filtering coefficients filters the material) and sampled
  // trilinearly; without it, texels are fetched as they are.
  const filtered = !!gl.getExtension('OES_texture_float_linear');
  const m = meta.degree + 1;
  const total = meta.params.reduce((a, p) => a + p.channels, 0) * m;
  const n = meta.width * meta.height;
  let unit = 0;
  let c0 = 0;
  for (const p of meta.params) {
    for (let k = 0; k < m; k++) {
      let tex = new Float32Array(n * 4);
      for (let i = 0; i < n; i++) {
        for (let c = 0; c < Math.min(p.channels, 4); c++) tex[i * 4 + c] = data[i * total + (c0 + c) * m + k];
        tex[i * 4 + 3] = 1;
      }
      gl.activeTexture(gl.TEXTURE0 + unit);
      gl.bindTexture(gl.TEXTURE_2D, gl.createTexture());
      let [w, h] = [meta.width, meta.height];
      gl.texImage2D(gl.TEXTURE_2D, 0, gl.RGBA32F, w, h, 0, gl.RGBA, gl.FLOAT, tex);
      let level = 0;
      while (filtered && (w > 1 || h > 1)) {
        const [nw, nh] = [Math.max(1, w >> 1), Math.max(1, h >> 1)];
        const next = new Float32Array(nw * nh * 4);
        for (let y = 0; y < nh; y++) {
          for (let x = 0; x < nw; x++) {
            for (let c = 0; c < 4; c++) {
              let sum = 0;
              for (const [dx, dy] of [[0, 0], [1, 0], [0, 1], [1, 1]]) sum += tex[(Math.min(2 * y + dy, h - 1) * w + Math.min(2 * x + dx, w - 1)) * 4 + c];
              next[(y * nw + x) * 4 + c] = sum / 4;
            }
          }
        }
        [tex, w, h] = [next, nw, nh];
        gl.texImage2D(gl.TEXTURE_2D, ++level, gl.RGBA32F, w, h, 0, gl.RGBA, gl.FLOAT, tex);
      }
      gl.texParameteri(gl.TEXTURE_2D, gl.TEXTURE_MIN_FILTER, filtered ? gl.LINEAR_MIPMAP_LINEAR : gl.NEAREST);
      gl.texParameteri(gl.TEXTURE_2D, gl.TEXTURE_MAG_FILTER, filtered ? gl.LINEAR : gl.NEAREST);
      gl.texParameteri(gl.TEXTURE_2D, gl.TEXTURE_WRAP_S, gl.REPEAT);
      gl.texParameteri(gl.TEXTURE_2D, gl.TEXTURE_WRAP_T, gl.CLAMP_TO_EDGE);
      gl.uniform1i(gl.getUniformLocation(prog, `${identOf(p.name)}_${k}`), unit);
      unit++;
    }
    c0 += p.channels;
  }
  const render = (t) => {
    gl.uniform1f(gl.getUniformLocation(prog, 't'), t);
    for (const mode of [0, 1]) {
      gl.viewport(mode * side, 0, side, side);
      gl.uniform1i(gl.getUniformLocation(prog, 'mode'), mode);
      gl.drawArrays(gl.TRIANGLE_STRIP, 0, 4);
    }
  };
  const maps = () => {
    $('panels').replaceChildren(...mapCanvases(meta, data, Number(slider.value)).map(([name, c]) => el('div', { className: 'panel' }, c, el('span', { textContent: `${name} at t = ${Number(slider.value).toFixed(2)}` }))));
  };
  let mapTimer = null;
  const update = () => {
    const t = Number(slider.value);
    label.textContent = `t = ${t.toFixed(2)}`;
    render(t);
    clearTimeout(mapTimer);
    mapTimer = setTimeout(maps, 60);
  };
  slider.addEventListener('input', update);
  let timer = null;
  play.onclick = () => {
    if (timer) { clearInterval(timer); timer = null; play.textContent = 'Play'; return; }
    play.textContent = 'Pause';
    timer = setInterval(() => { slider.value = ((Number(slider.value) + 0.01) % 1.0001).toFixed(2); update(); }, 50);
  };
  setContentSize(2 * side, side);
  update();
  maps();
  if (SELFTEST) {
    const pixels = () => {
      const px = new Uint8Array(2 * side * side * 4);
      gl.readPixels(0, 0, 2 * side, side, gl.RGBA, gl.UNSIGNED_BYTE, px);
      return px;
    };
    const a = pixels();
    let lit = 0;
    let sumA = 0;
    for (let i = 0; i < a.length; i += 4) {
      const v = a[i] + a[i + 1] + a[i + 2];
      sumA += v;
      if (Math.abs(a[i] - 31) > 6 || Math.abs(a[i + 1] - 31) > 6) lit++;
    }
    slider.value = 1;
    slider.dispatchEvent(new Event('input'));
    const b = pixels();
    let sumB = 0;
    for (let i = 0; i < b.length; i += 4) sumB += b[i] + b[i + 1] + b[i + 2];
    return { view: 'material', slider: !!$('time'), webgl: true, nonBlankShare: lit / (a.length / 4), frameChanged: sumA !== sumB };
  }
  return null;
}

// ---- Start -----------------------------------------------------------------------

async function start() {
  enablePan();
  let result;
  try {
    const listing = await (await fetch('/api/listing')).json();
    const m = listing.manifest;
    if (listing.material) result = await materialView(listing);
    else if (m && Array.isArray(m.frames) && m.frames.length) result = await sequenceView(listing);
    else result = await galleryView(listing);
  } catch (e) {
    $('what').textContent = `error: ${e.message}`;
    result = { error: String(e.message || e) };
  }
  if (SELFTEST) {
    $('selftest').textContent = JSON.stringify(result);
    $('selftest').hidden = false;
  }
}

start();
