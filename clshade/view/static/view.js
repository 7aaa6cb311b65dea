// clshade view — the page: sends the whole control state on every change (the server keeps
// only the newest), draws the frames it gets back (A, B, |A − B|), shows their cost.
"use strict";
const $ = (id) => document.getElementById(id);
const token = new URLSearchParams(location.search).get("token");
const ws = new WebSocket(`ws://${location.host}/ws${token ? "?token=" + encodeURIComponent(token) : ""}`);
ws.binaryType = "arraybuffer";

let hello = null, controls = null, seq = 0, divider = 0.5, lastFrame = null;
const sentAt = new Map();          // seq → performance.now() when the state was sent
const latencies = [];              // input → displayed, ms, recent frames
const waiters = [];                // [seq, resolve]: frameFor()
const records = [];                // per displayed frame: {seq, latency, server, stages}
const canvas = $("frame"), ctx = canvas.getContext("2d", {alpha: false});
let views = {};
const progress = [];               // the sky error's progress messages, for tests
const skyErrors = {};              // cost label → the sky error's relative RMSE, once measured

function send(message) {
  if (ws.readyState === WebSocket.OPEN) ws.send(JSON.stringify(message));
}
function update() {                // the controls changed: ask for a frame
  seq += 1;
  sentAt.set(seq, performance.now());
  send({type: "state", seq, controls});
  return seq;
}
function showError(text) { $("error").textContent = text || ""; }
// Text written only when it changed: a rewrite costs the browser a style, layout and paint per frame.
function setText(element, value) { if (element.textContent !== value) element.textContent = value; }

// ------------------------------------------------------------------ frames

function draw() {
  if (!views.a) return;
  const w = canvas.width, h = canvas.height;
  if (controls.diff && views.diff) {
    ctx.putImageData(views.diff, 0, 0);
  } else {
    ctx.putImageData(views.a, 0, 0);
    if (controls.split && views.b) {
      const x = Math.round(divider * w);
      ctx.putImageData(views.b, 0, 0, x, 0, w - x, h);
      ctx.fillStyle = "#fff";
      ctx.fillRect(x, 0, 1, h);
    }
  }
}

// Each view's pixels (server.py's encode_view): per run of `segment` pixels a flag (1: its pixels
// follow, 0: all of them are the background value), then the flagged runs' pixels. Decoded into an
// ImageData kept per view and size (putImageData copies it: the next frame may overwrite it).
const kept = {};
function decodeView(name, buffer, offset, w, h, segment, background) {
  const npix = w * h, runs = Math.ceil(npix / segment);
  if (!kept[name] || kept[name].width !== w || kept[name].height !== h) kept[name] = new ImageData(w, h);
  const out = new Uint32Array(kept[name].data.buffer);
  const flags = new Uint8Array(buffer, offset, runs);
  offset += runs + (-runs & 3);
  let from = offset / 4;
  const words = new Uint32Array(buffer);
  for (let k = 0; k < runs;) {
    let end = k;
    while (end < runs && flags[end] === flags[k]) end++;
    const a = k * segment, b = Math.min(end * segment, npix);
    if (flags[k]) { out.set(words.subarray(from, from + b - a), a); from += b - a; }
    else out.fill(background, a, b);
    k = end;
  }
  return [kept[name], from * 4];
}

function onFrame(buffer) {
  const received = performance.now();
  const n = new DataView(buffer).getUint32(0, true);
  const header = JSON.parse(new TextDecoder().decode(new Uint8Array(buffer, 4, n)));
  const w = header.width, h = header.height, e = header.encoding;
  if (canvas.width !== w || canvas.height !== h) { canvas.width = w; canvas.height = h; }
  views = {};
  let offset = 4 + n;
  for (const name of header.views) {
    [views[name], offset] = decodeView(name, buffer, offset, w, h, e.segment, e.background[name]);
  }
  draw();
  const now = performance.now();
  const latency = sentAt.has(header.seq) ? now - sentAt.get(header.seq) : null;
  for (const k of sentAt.keys()) if (k <= header.seq) sentAt.delete(k);
  if (latency !== null) { latencies.push(latency); if (latencies.length > 120) latencies.shift(); }
  lastFrame = header;
  records.push({seq: header.seq, latency, displayed: now, draw_ms: now - received, bytes: buffer.byteLength,
                stages: header.stages, reshade_only: header.reshade_only});
  if (records.length > 1000) records.shift();
  if ($("error").dataset.seq && +$("error").dataset.seq < header.seq) showError("");
  costShown(header);
  $("legend").hidden = !(controls.diff && views.diff);
  if (header.diff_scale !== null) setText($("scale"), header.diff_scale.toFixed(3));
  const sky = header.environment;
  setText($("rungs"), sky ? `${sky.sky}: ${sky.rungs} · variant ${sky.variant}` : "no environment");
  for (let i = waiters.length - 1; i >= 0; i--) {
    if (header.seq >= waiters[i][0]) { waiters[i][1]({seq: header.seq, latency}); waiters.splice(i, 1); }
  }
}

// The cost readouts change every frame; text rewritten at 30 Hz cannot be read and costs the
// browser a layout and paint each time: they are redrawn at most every COST_INTERVAL_MS, always
// with the newest frame's figures (a trailing update shows the last frame of a burst).
const COST_INTERVAL_MS = 250;
let costTimer = null, costHeader = null, costAt = -Infinity;
function costShown(header) {
  costHeader = header;
  if (costTimer !== null) return;
  const wait = costAt + COST_INTERVAL_MS - performance.now();
  const show = () => { costTimer = null; costAt = performance.now(); showCost(costHeader); };
  if (wait <= 0) show(); else costTimer = setTimeout(show, wait);
}

function showCost(header) {
  const body = $("cost").tBodies[0];
  body.innerHTML = "";
  for (const [view, model] of Object.entries(header.models)) {
    const s = header.stats[header.costs[view]];
    const row = body.insertRow();
    [`${view.toUpperCase()} ${header.costs[view]}`, s.mean_ms.toFixed(2), s.avg_fps.toFixed(0), s.low1_fps.toFixed(0)]
      .forEach((t) => { row.insertCell().textContent = t; });
  }
  showLadder(header.ladder);
  $("stages").textContent = "frame: " + Object.entries(header.stages)
    .map(([k, v]) => `${k} ${v.toFixed(1)}`).join(" · ") + " ms";
  const sorted = [...latencies].sort((a, b) => a - b);
  const median = sorted.length ? sorted[Math.floor(sorted.length / 2)] : 0;
  $("latency").textContent = `input → displayed: median ${median.toFixed(1)} ms over ${sorted.length} frames; ` +
    `${header.skipped} stale states skipped`;
}

function showLadder(ladder) {       // every model and rung shaded so far: its cost and, once measured, its error
  const body = $("ladder").tBodies[0];
  body.innerHTML = "";
  for (const label of Object.keys(ladder).sort()) {
    const row = body.insertRow();
    [label, ladder[label].toFixed(2), skyErrors[label] != null ? skyErrors[label].toExponential(2) : ""]
      .forEach((t) => { row.insertCell().textContent = t; });
  }
}

function showSkyError(m) {
  const e = (x) => x === null ? "—" : x.toExponential(2);       // no error where the truth is all zero
  skyErrors[m.label] = m.rel_rmse;
  const grazing = m.by_nv.find((bin) => bin.pixels > 0);
  $("sky_error_out").textContent = `${m.label}: rel RMSE ${e(m.rel_rmse)}, max ${e(m.max_rel)} over ${m.pixels} pixels` +
    (grazing ? `; n·v ≤ ${grazing.nv[1]}: ${e(grazing.rel_rmse)}` : "");
  if (lastFrame) showLadder(lastFrame.ladder);
}

// ------------------------------------------------------------------ canvas size

// The canvas fills the space beside the panel; it is rendered at its CSS size × the device pixel ratio ×
// the resolution control (the server caps it, its aspect kept), or at the command's size ("fixed").
const STAGE_MARGIN_PX = 30, LEGEND_PX = 40;
function canvasSize() {
  const mode = $("resolution").value, ratio = window.devicePixelRatio || 1;
  if (mode === "fixed") return {css: [hello.width / ratio, hello.height / ratio], pixels: [hello.width, hello.height]};
  const cssW = Math.max(1, Math.floor(window.innerWidth - $("panel").offsetWidth - STAGE_MARGIN_PX));
  const cssH = Math.max(1, Math.floor(window.innerHeight - $("stage").getBoundingClientRect().top - LEGEND_PX));
  const scale = +mode * ratio;
  return {css: [cssW, cssH], pixels: [Math.max(1, Math.round(cssW * scale)), Math.max(1, Math.round(cssH * scale))]};
}

function layout() {                // the canvas's size followed: a new state when its pixels changed
  if (!controls) return;
  const size = canvasSize();
  canvas.style.width = `${size.css[0]}px`; canvas.style.height = `${size.css[1]}px`;
  if (controls.width !== size.pixels[0] || controls.height !== size.pixels[1]) {
    [controls.width, controls.height] = size.pixels;
    update();
  }
}
window.addEventListener("resize", layout);

// ------------------------------------------------------------------ messages

ws.onmessage = (event) => {
  if (typeof event.data !== "string") { onFrame(event.data); return; }
  const m = JSON.parse(event.data);
  if (m.type === "hello") start(m);
  else if (m.type === "error") { showError(m.message); $("error").dataset.seq = m.seq ?? seq; }
  else if (m.type === "saved") $("saved").textContent = `wrote ${m.files.join(", ")} in ${m.folder}\n` + m.commands.join("\n");
  else if (m.type === "oracle") showOracle(m);
  else if (m.type === "sky_progress" && progress.push(m)) {
    $("sky_error_out").textContent = `measuring ${m.label}: ${m.done}/${m.total} pixels…`;
  }
  else if (m.type === "sky_error") showSkyError(m);
  else if (m.type === "sent") {
    const r = records.findLast((x) => x.seq === m.seq);
    if (r) Object.assign(r, {server_ms: m.server_ms, pack_ms: m.pack_ms, render_ms: m.render_ms});
  }
};
ws.onopen = () => { $("status").textContent = "connected"; };
ws.onclose = () => { $("status").textContent = "disconnected (the server stopped)"; };
window.addEventListener("pagehide", () => send({type: "bye"}));

function showOracle(m) {
  const t = $("truth");
  t.innerHTML = "<tr><th>model</th><th>max rel</th><th>mean rel</th><th>NaN</th><th>Inf</th><th>&lt;0</th></tr>";
  for (const [view, r] of Object.entries(m.models)) {
    const row = t.insertRow();
    [`${view.toUpperCase()} ${r.model}`, r.max_rel_error.toExponential(2), r.mean_rel_error.toExponential(2),
     r.nan, r.inf, r.negative].forEach((x) => { row.insertCell().textContent = x; });
  }
  const row = t.insertRow();
  const cell = row.insertCell(); cell.colSpan = 6; cell.className = "note";
  cell.textContent = `${m.covered_samples} covered samples, ${m.grazing_samples} grazing left out, ` +
    `${m.nonfinite_inputs} non-finite G-buffer inputs; raw radiance counted before any clamp`;
}

// ------------------------------------------------------------------ controls

function lobesOf(spec) {
  const text = spec.split("/")[0].split("@")[0].trim().toLowerCase();
  const out = [];
  for (const part of text.split("+")) {
    const preset = hello.presets.find((p) => p.id === part);
    if (preset) out.push(...[preset.diffuse, preset.specular].filter((x) => x !== "none"));
    else out.push(part);
  }
  return out;
}

function sliderParams() {             // the surface inputs (base colour, metallic), then the lobes' parameters
  const names = new Set(Object.keys(hello.params).filter((name) => hello.surface.includes(name)));
  for (const spec of [controls.model_a, controls.model_b]) {
    for (const id of lobesOf(spec)) {
      const lobe = hello.lobes.find((l) => l.id === id);
      if (lobe) lobe.params.forEach((p) => { if (p.name in hello.params) names.add(p.name); });
    }
  }
  return [...names];
}

// A slider position in [0, 1000] ↔ a value; wide ranges (shininess to 1e6) on a log scale.
const isLog = (p) => p.max / Math.max(p.min, 1) > 1000;
const toValue = (p, s) => isLog(p) ? Math.min(p.max, p.min + Math.pow(10, s / 1000 * Math.log10(p.max - p.min + 1)) - 1)
                                   : p.min + (p.max - p.min) * s / 1000;
const toSlider = (p, v) => isLog(p) ? 1000 * Math.log10(v - p.min + 1) / Math.log10(p.max - p.min + 1)
                                    : 1000 * (v - p.min) / (p.max - p.min);

function materialValue(name, param) {
  return controls.materials[name]?.[param] ?? hello.materials[name][param];
}

function slider(id, text, p, value, set) {     // one range input with its label and value
  const label = document.createElement("label");
  const input = Object.assign(document.createElement("input"), {type: "range", min: 0, max: 1000, step: 1, id});
  const out = document.createElement("output");
  input.value = toSlider(p, value);
  out.textContent = (+value).toPrecision(3);
  input.addEventListener("input", () => {
    const v = toValue(p, +input.value);
    out.textContent = v.toPrecision(3);
    set(v);
    update();
  });
  label.title = p.text || "";
  label.append(`${text} `, input, out);
  return label;
}

function buildSliders() {
  const box = $("params"), name = $("material").value;
  box.innerHTML = "";
  if (!name) return;
  for (const param of sliderParams()) {
    const p = hello.params[param];
    if (p.kind === "color") {            // one slider per channel; the control value is [R, G, B]
      ["R", "G", "B"].forEach((channel, i) => {
        box.append(slider(`param_${param}_${i}`, `${param} ${channel}`, p, materialValue(name, param)[i], (v) => {
          const rgb = [...materialValue(name, param)];
          rgb[i] = v;
          (controls.materials[name] ??= {})[param] = rgb;
        }));
      });
    } else {
      box.append(slider(`param_${param}`, param, p, materialValue(name, param),
                        (v) => { (controls.materials[name] ??= {})[param] = v; }));
    }
  }
}

function cameraBasis() {                  // right, up, back (towards the camera) in world space
  const o = hello.orbit, a = controls.azimuth * Math.PI / 180, e = controls.elevation * Math.PI / 180;
  const ring = o.east.map((x, i) => Math.cos(a) * x + Math.sin(a) * o.north[i]);
  const back = ring.map((x, i) => Math.cos(e) * x + Math.sin(e) * o.up[i]);
  const cross = (u, v) => [u[1] * v[2] - u[2] * v[1], u[2] * v[0] - u[0] * v[2], u[0] * v[1] - u[1] * v[0]];
  const norm = (v) => { const l = Math.hypot(...v); return v.map((x) => x / l); };
  const right = norm(cross(o.up, back));
  return [right, cross(back, right), back];
}

function lightDirection(index) {
  return controls.lights[index]?.direction ?? hello.lights[index].direction;
}

function drawSphere() {
  const c = $("sphere").getContext("2d"), r = 56, cx = 60, cy = 60;
  c.clearRect(0, 0, 120, 120);
  const index = +$("light").value, d = hello.lights[index] && lightDirection(index);
  const img = c.createImageData(120, 120);
  const [right, up, back] = cameraBasis();
  const from = d ? [-d[0], -d[1], -d[2]] : [0, 0, 0];
  const lv = d ? [right, up, back].map((axis) => axis[0] * from[0] + axis[1] * from[1] + axis[2] * from[2]) : [0, 0, 1];
  for (let y = 0; y < 120; y++) for (let x = 0; x < 120; x++) {
    const u = (x - cx) / r, v = (cy - y) / r, w2 = 1 - u * u - v * v;
    if (w2 < 0) continue;
    const shade = Math.max(0, u * lv[0] + v * lv[1] + Math.sqrt(w2) * lv[2]);
    const k = (y * 120 + x) * 4, g = 40 + 200 * shade;
    img.data.set([g, g, g * 0.95, 255], k);
  }
  c.putImageData(img, 0, 0);
  if (d && lv[2] >= 0) {
    c.strokeStyle = "#fc4"; c.beginPath(); c.arc(cx + lv[0] * r, cy - lv[1] * r, 5, 0, 7); c.stroke();
  }
}

function sphereDrag(event) {
  const index = +$("light").value;
  if (!hello.lights[index] || hello.lights[index].kind === "point") return;
  const rect = $("sphere").getBoundingClientRect();
  let u = (event.clientX - rect.left - 60) / 56, v = (60 - (event.clientY - rect.top)) / 56;
  const len = Math.hypot(u, v);
  if (len > 1) { u /= len; v /= len; }
  const w = Math.sqrt(Math.max(0, 1 - u * u - v * v));
  const [right, up, back] = cameraBasis();
  const from = [0, 1, 2].map((i) => u * right[i] + v * up[i] + w * back[i]);
  (controls.lights[index] ??= {}).direction = from.map((x) => -x);
  drawSphere();
  update();
}

function start(m) {
  hello = m;
  controls = structuredClone(m.controls);
  $("scene").textContent = `${m.scene} · ${m.width}×${m.height}`;
  const ramp = $("ramp").getContext("2d");
  m.ramp.forEach((rgb, i) => { ramp.fillStyle = `rgb(${rgb.join(",")})`; ramp.fillRect(i, 0, 1, 10); });
  canvas.width = m.width; canvas.height = m.height;      // until the first frame of the canvas's own size
  const list = $("models");
  for (const p of m.presets) list.append(new Option(p.name, p.id));
  for (const l of m.lobes) list.append(new Option(`${l.name} (${l.kind} lobe)`, l.id));
  list.append(new Option("Oren–Nayar + GGX, exact conductor Fresnel", "oren_nayar+ggx_correlated@conductor"));
  for (const name of Object.keys(m.materials)) $("material").append(new Option(name, name));
  m.lights.forEach((l, i) => $("light").append(new Option(`${i}: ${l.kind}`, i)));
  for (const id of ["model_a", "model_b"]) {
    $(id).value = controls[id];
    $(id).addEventListener("change", () => { controls[id] = $(id).value.trim(); buildSliders(); update(); });
  }
  for (const id of ["split", "diff", "specular_aa"]) {
    $(id).checked = controls[id];
    $(id).addEventListener("change", () => { controls[id] = $(id).checked; update(); });
  }
  $("exposure").value = controls.exposure; $("exposure_out").textContent = controls.exposure;
  $("exposure").addEventListener("input", () => {
    controls.exposure = +$("exposure").value; $("exposure_out").textContent = controls.exposure; update();
  });
  $("tonemap").value = controls.tonemap;
  $("tonemap").addEventListener("change", () => { controls.tonemap = $("tonemap").value; update(); });
  $("samples").value = String(controls.samples);
  $("samples").addEventListener("change", () => { controls.samples = +$("samples").value; update(); });
  startSky(m);
  $("resolution").value = m.fixed_size ? "fixed" : "1";
  $("resolution").addEventListener("change", layout);
  $("material").addEventListener("change", buildSliders);
  $("light").addEventListener("change", () => {
    $("intensity").value = controls.lights[$("light").value]?.scale ?? 1; drawSphere();
  });
  $("intensity").addEventListener("input", () => {
    (controls.lights[$("light").value] ??= {}).scale = +$("intensity").value;
    $("intensity_out").textContent = $("intensity").value; update();
  });
  let dragging = false;
  $("sphere").addEventListener("pointerdown", (e) => { dragging = true; sphereDrag(e); });
  $("sphere").addEventListener("pointermove", (e) => { if (dragging) sphereDrag(e); });
  window.addEventListener("pointerup", () => { dragging = false; });
  $("save").addEventListener("click", () => send({type: "save", seq: ++seq, name: $("save_name").value, controls}));
  $("oracle").addEventListener("click", () => {
    $("truth").innerHTML = "<tr><td>measuring…</td></tr>"; send({type: "oracle", seq: ++seq, controls});
  });
  buildSliders();
  drawSphere();
  const size = canvasSize();
  [controls.width, controls.height] = size.pixels;
  canvas.style.width = `${size.css[0]}px`; canvas.style.height = `${size.css[1]}px`;
  update();
}

function startSky(m) {             // the environment picker and the rung controls, from the server's lists
  const sky = controls.environment;
  if (m.scene_sky) $("sky").append(new Option("the scene's own", ""));
  for (const name of m.skies) $("sky").append(new Option(name, name));
  for (const rung of m.rungs.diffuse) $("env_diffuse").append(new Option(rung, rung));
  for (const rung of m.rungs.specular) $("env_specular").append(new Option(rung, rung));
  $("env_samples").max = m.rungs.max_samples;
  $("sky").value = sky.sky ?? "";
  $("env_diffuse").value = sky.diffuse; $("env_specular").value = sky.specular; $("env_samples").value = sky.samples;
  $("env_rotation").value = sky.rotation; $("env_rotation_out").textContent = sky.rotation;
  $("env_intensity").value = sky.intensity; $("env_intensity_out").textContent = sky.intensity;
  const set = (key, value) => { controls.environment[key] = value; update(); };
  $("sky").addEventListener("change", () => set("sky", $("sky").value === "" ? null : $("sky").value));
  $("env_diffuse").addEventListener("change", () => set("diffuse", $("env_diffuse").value));
  $("env_specular").addEventListener("change", () => set("specular", $("env_specular").value));
  $("env_samples").addEventListener("change", () => {
    const n = Math.round(+$("env_samples").value);
    if (n >= 1 && n <= m.rungs.max_samples) set("samples", n);
  });
  $("env_rotation").addEventListener("input", () => {
    $("env_rotation_out").textContent = $("env_rotation").value; set("rotation", +$("env_rotation").value);
  });
  $("env_intensity").addEventListener("input", () => {
    $("env_intensity_out").textContent = $("env_intensity").value; set("intensity", +$("env_intensity").value);
  });
  $("sky_error").addEventListener("click", () => {
    $("sky_error_out").textContent = "measuring…"; send({type: "sky_error", seq: ++seq, controls});
  });
}

// Orbit (drag), zoom (wheel), split divider (drag near the line).
let drag = null;
canvas.addEventListener("pointerdown", (e) => {
  const x = e.offsetX / canvas.clientWidth;
  drag = {x: e.clientX, y: e.clientY, divider: controls?.split && !controls.diff && Math.abs(x - divider) * canvas.width < 6};
  canvas.setPointerCapture(e.pointerId);
});
canvas.addEventListener("pointermove", (e) => {
  if (!drag || !controls) return;
  if (drag.divider) {
    divider = Math.min(1, Math.max(0, e.offsetX / canvas.clientWidth));
    draw();
    return;
  }
  controls.azimuth -= (e.clientX - drag.x) * 0.4;
  controls.elevation = Math.max(-89, Math.min(89, controls.elevation + (e.clientY - drag.y) * 0.3));
  drag.x = e.clientX; drag.y = e.clientY;
  drawSphere();
  update();
});
canvas.addEventListener("pointerup", () => { drag = null; });
canvas.addEventListener("wheel", (e) => {
  e.preventDefault();
  if (!controls) return;
  const [lo, hi] = hello.distance;
  controls.distance = Math.min(hi, Math.max(lo, controls.distance * Math.exp(e.deltaY * 0.001)));
  update();
}, {passive: false});

// For tests and the benchmark (benchmarks/measure/view_bench.py): drive the page, read what it shows.
window.clshadeView = {
  get controls() { return controls; }, get lastFrame() { return lastFrame; }, get hello() { return hello; },
  records, latencies, progress,
  set(patch) { Object.assign(controls, patch); return update(); },
  send(message) { send(message); },
  sendRaw(text) { ws.send(text); },
  lastSeq() { return seq; },
  view(name) { return views[name].data; },
  frameFor(s) {
    return new Promise((resolve) => {
      if (lastFrame && lastFrame.seq >= s) resolve({seq: lastFrame.seq, latency: records.at(-1).latency});
      else waiters.push([s, resolve]);
    });
  },
  setDivider(x) { divider = x; draw(); },
  canvasPNG() { return canvas.toDataURL("image/png"); },
  error() { return $("error").textContent; },
};
