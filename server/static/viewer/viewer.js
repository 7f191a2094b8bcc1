// PhysMind web viewer: plain JavaScript over the server's JSON API (no build step).
// Worlds -> objects and fitted parameters -> the rollout in a top-down canvas with a scrubber and
// an event timeline; a form per tool built from its JSON Schema; two rollouts side by side.
"use strict";

// Mirrors render/style.py (COLOR_RGB, COLLISION_COLOR, DIVERGING_COLOR) and render/scene.py (EVENT_MATCH_FRAMES).
const COLORS = {
  gray: "rgb(150,150,150)", red: "rgb(220,50,47)", blue: "rgb(38,110,230)", green: "rgb(40,170,70)",
  brown: "rgb(150,95,45)", yellow: "rgb(235,200,20)", cyan: "rgb(30,200,210)", purple: "rgb(150,70,200)",
};
const UNKNOWN_COLOR = "rgb(240,240,240)";
const COLLISION_COLOR = "rgb(255,140,0)";
const DIVERGING_COLOR = "rgb(230,0,120)";
const EVENT_MATCH_FRAMES = 5;
const MARKER_SECONDS = 0.2;
const ROLLOUT_ARGUMENTS = new Set(["rollout_id", "based_on", "reference_rollout_id", "edited_rollout_id"]);

const state = {
  worldId: null, world: null, summary: null, rollouts: new Map(), rolloutIds: [], current: "base",
  frame: 0, playing: false, tools: [], compare: null, painted: false,
};
const $ = (id) => document.getElementById(id);

// -- HTTP ----------------------------------------------------------------------------------
function headers(extra = {}) {
  const key = localStorage.getItem("physmind-api-key");
  return key ? { ...extra, Authorization: `Bearer ${key}` } : extra;
}

async function api(path, options = {}) {
  const response = await fetch(path, { ...options, headers: headers(options.headers || {}) });
  const text = await response.text();
  let body;
  try { body = text ? JSON.parse(text) : {}; } catch (e) { body = { error: { code: "bad_response", message: text.slice(0, 200) } }; }
  if (!response.ok) {
    const error = new Error((body.error && `${body.error.code}${body.error.pointer ? " at " + body.error.pointer : ""}: ${body.error.message}`) || response.statusText);
    error.body = body;
    throw error;
  }
  return body;
}

function setStatus(text, isError = false) {
  $("status").textContent = text;
  $("status").classList.toggle("error", isError);
}

// -- geometry ------------------------------------------------------------------------------
function bodyOf(id) { return state.world.bodies.find((b) => b.id === id); }

function fitView(rollouts, canvas) {
  let xmin = Infinity, xmax = -Infinity, ymin = Infinity, ymax = -Infinity, radius = 0.3;
  for (const b of state.world.bodies) radius = Math.max(radius, b.shape.kind === "cube" ? b.shape.half_extent * Math.SQRT2 : b.shape.radius);
  for (const r of rollouts) {
    r.positions.forEach((row, t) => row.forEach((p, n) => {
      if (!r.active[t][n]) return;
      xmin = Math.min(xmin, p[0]); xmax = Math.max(xmax, p[0]); ymin = Math.min(ymin, p[1]); ymax = Math.max(ymax, p[1]);
    }));
  }
  if (!isFinite(xmin)) { xmin = -1; xmax = 1; ymin = -1; ymax = 1; }
  const pad = radius + 0.3;
  xmin -= pad; xmax += pad; ymin -= pad; ymax += pad;
  const scale = Math.min(canvas.width / (xmax - xmin), (canvas.height - 20) / (ymax - ymin));
  const cx = (xmin + xmax) / 2, cy = (ymin + ymax) / 2;
  return {
    scale, xmin, xmax, ymin, ymax,
    px: (x, y) => [canvas.width / 2 + (x - cx) * scale, 10 + (canvas.height - 20) / 2 - (y - cy) * scale],
  };
}

function footprint(body, p, yaw, view) {
  const s = body.shape;
  if (s.kind !== "cube") return { circle: view.px(p[0], p[1]), r: s.radius * view.scale };
  const h = s.half_extent, c = Math.cos(yaw), sn = Math.sin(yaw);
  return { polygon: [[h, h], [-h, h], [-h, -h], [h, -h]].map(([x, y]) => view.px(p[0] + c * x - sn * y, p[1] + sn * x + c * y)) };
}

// Events of two rollouts correspond when kind and objects agree within EVENT_MATCH_FRAMES (render/scene.py).
function divergingEvents(reference, edited) {
  const key = (e) => `${e.kind}:${[...e.bodies].sort((a, b) => a - b).join("-")}`;
  const used = new Set();
  const refFlags = reference.map((e) => {
    let best = -1, gap = Infinity;
    edited.forEach((o, j) => {
      const d = Math.abs(o.frame - e.frame);
      if (!used.has(j) && key(o) === key(e) && d <= EVENT_MATCH_FRAMES && d < gap) { best = j; gap = d; }
    });
    if (best >= 0) used.add(best);
    return best < 0;
  });
  return [refFlags, edited.map((_, j) => !used.has(j))];
}

// -- drawing -------------------------------------------------------------------------------
function drawRollout(canvas, rollout, frame, view, title, flags = []) {
  const g = canvas.getContext("2d");
  g.fillStyle = "#fafaf8"; g.fillRect(0, 0, canvas.width, canvas.height);
  g.strokeStyle = "#e1e1dc"; g.lineWidth = 1;
  for (let x = Math.floor(view.xmin); x <= Math.ceil(view.xmax); x++) { const [u] = view.px(x, 0); g.beginPath(); g.moveTo(u, 0); g.lineTo(u, canvas.height); g.stroke(); }
  for (let y = Math.floor(view.ymin); y <= Math.ceil(view.ymax); y++) { const [, v] = view.px(0, y); g.beginPath(); g.moveTo(0, v); g.lineTo(canvas.width, v); g.stroke(); }
  const f = Math.min(frame, rollout.horizon_frames - 1);
  rollout.body_ids.forEach((id, n) => {
    const body = bodyOf(id);
    const color = COLORS[body.color] || UNKNOWN_COLOR;
    g.strokeStyle = color; g.lineWidth = 1.5; g.beginPath();
    let started = false;
    for (let t = 0; t <= f; t++) {
      if (!rollout.active[t][n]) { started = false; continue; }
      const [u, v] = view.px(rollout.positions[t][n][0], rollout.positions[t][n][1]);
      if (started) g.lineTo(u, v); else { g.moveTo(u, v); started = true; }
    }
    g.stroke();
    if (!rollout.active[f][n]) return;
    const p = rollout.positions[f][n], shape = footprint(body, p, rollout.yaw[f][n], view);
    g.fillStyle = color; g.strokeStyle = "#222"; g.lineWidth = 1; g.beginPath();
    if (shape.circle) g.arc(shape.circle[0], shape.circle[1], shape.r, 0, 2 * Math.PI);
    else { g.moveTo(...shape.polygon[0]); shape.polygon.slice(1).forEach((q) => g.lineTo(...q)); g.closePath(); }
    g.fill(); g.stroke();
    const [u, v] = view.px(p[0], p[1]);
    const vel = rollout.velocities[f][n], [tu, tv] = view.px(p[0] + 0.3 * vel[0], p[1] + 0.3 * vel[1]);
    if (Math.hypot(tu - u, tv - v) > 3) { g.beginPath(); g.moveTo(u, v); g.lineTo(tu, tv); g.stroke(); }
    g.fillStyle = "#111"; g.font = "12px sans-serif"; g.fillText(String(id), u + 6, v - 8);
  });
  rollout.events.forEach((e, i) => {
    if (e.kind !== "collision" || e.frame > f) return;
    const [u, v] = view.px(e.position[0], e.position[1]);
    g.strokeStyle = flags[i] ? DIVERGING_COLOR : COLLISION_COLOR; g.lineWidth = 2.5; g.beginPath();
    if (f - e.frame <= MARKER_SECONDS * rollout.fps) g.arc(u, v, 10, 0, 2 * Math.PI);
    else { g.moveTo(u - 4, v - 4); g.lineTo(u + 4, v + 4); g.moveTo(u - 4, v + 4); g.lineTo(u + 4, v - 4); }
    g.stroke();
  });
  g.fillStyle = "#111"; g.font = "13px sans-serif";
  g.fillText(`${title}   frame ${f}  t ${(f / rollout.fps).toFixed(2)} s${f >= rollout.observed_frames ? "  (beyond the video)" : ""}`, 6, 14);
}

function drawTimeline(canvas, rows, cursor) {
  const g = canvas.getContext("2d");
  g.fillStyle = "#fff"; g.fillRect(0, 0, canvas.width, canvas.height);
  const horizon = Math.max(...rows.map((r) => r.rollout.horizon_frames)), fps = rows[0].rollout.fps;
  const x0 = 110, x1 = canvas.width - 8, last = Math.max(horizon - 1, 1), axis = canvas.height - 18;
  const x = (frame) => x0 + (x1 - x0) * frame / last;
  g.strokeStyle = "#222"; g.fillStyle = "#222"; g.font = "10px sans-serif";
  g.beginPath(); g.moveTo(x0, axis); g.lineTo(x1, axis); g.stroke();
  for (let s = 0; s * fps <= last; s++) { g.beginPath(); g.moveTo(x(s * fps), axis); g.lineTo(x(s * fps), axis + 4); g.stroke(); g.fillText(`${s}s`, x(s * fps) - 5, axis + 14); }
  g.setLineDash([3, 3]); g.strokeStyle = "#888";
  const end = x(Math.min(rows[0].rollout.observed_frames, last));
  g.beginPath(); g.moveTo(end, 2); g.lineTo(end, axis); g.stroke(); g.setLineDash([]);
  const rowHeight = (axis - 4) / rows.length;
  rows.forEach((row, k) => {
    const y = 4 + rowHeight * (k + 0.5);
    g.fillStyle = "#222"; g.font = "11px sans-serif"; g.fillText(row.label.slice(0, 18), 4, y + 4);
    g.strokeStyle = "#e1e1dc"; g.beginPath(); g.moveTo(x0, y); g.lineTo(x1, y); g.stroke();
    row.rollout.events.forEach((e, i) => {
      const flagged = row.flags && row.flags[i];
      const color = flagged ? DIVERGING_COLOR : (e.kind === "collision" ? COLLISION_COLOR : "#6e6e6e");
      g.fillStyle = color; g.strokeStyle = color;
      if (e.kind === "collision") {
        g.beginPath(); g.arc(x(e.frame), y, flagged ? 5 : 4, 0, 2 * Math.PI); g.fill();
        g.font = "9px sans-serif"; g.fillText(e.bodies.join("-"), x(e.frame) - 6, y - 7);
      } else {
        g.lineWidth = flagged ? 2 : 1; g.beginPath(); g.moveTo(x(e.frame), y - 5); g.lineTo(x(e.frame), y + 5); g.stroke(); g.lineWidth = 1;
      }
    });
  });
  if (cursor !== null) { g.strokeStyle = "rgb(220,0,0)"; g.lineWidth = 2; g.beginPath(); g.moveTo(x(cursor), 0); g.lineTo(x(cursor), canvas.height); g.stroke(); g.lineWidth = 1; }
  return (px) => Math.round(Math.min(Math.max((px - x0) / (x1 - x0), 0), 1) * last);
}

// -- the player ----------------------------------------------------------------------------
function label(rollout) {
  if (!rollout.edits.length) return "factual (base)";
  return "edited: " + rollout.edits.map((e) => `${e.kind} ${e.body}${e.value === null || e.value === undefined ? "" : " " + JSON.stringify(e.value)}`).join("; ");
}

function renderPlayer() {
  const rollout = state.rollouts.get(state.current);
  if (!rollout) return;
  const canvas = $("canvas");
  // One view for the factual and the shown rollout, so switching between them does not move the picture.
  if (!state.view || state.viewFor !== state.current) { state.view = fitView([state.rollouts.get("base"), rollout], canvas); state.viewFor = state.current; }
  drawRollout(canvas, rollout, state.frame, state.view, label(rollout));
  const base = state.rollouts.get("base");
  const rows = [{ label: "factual", rollout: base, flags: [] }];
  if (rollout !== base) {
    const [refFlags, flags] = divergingEvents(base.events, rollout.events);
    rows[0].flags = refFlags;
    rows.push({ label: "edited", rollout, flags });
  }
  state.seek = drawTimeline($("timeline"), rows, state.frame);
  $("scrubber").value = state.frame;
  $("frame-label").textContent = `frame ${state.frame} / ${rollout.horizon_frames - 1}`;
  if (!state.painted) {
    state.painted = true;
    window.physmindTimings = { firstWorldPaintMs: performance.now() };
    canvas.dataset.painted = "1";
  }
}

async function loadRollout(id) {
  if (!state.rollouts.has(id)) {
    const body = await api(`/v1/worlds/${state.worldId}/rollouts/${encodeURIComponent(id)}?detail=full`);
    state.rollouts.set(id, body.rollout);
  }
  return state.rollouts.get(id);
}

async function showRollout(id) {
  const rollout = await loadRollout(id);
  state.current = id;
  state.frame = Math.min(state.frame, rollout.horizon_frames - 1);
  $("scrubber").max = rollout.horizon_frames - 1;
  $("rollout-select").value = id;
  const base = `/v1/worlds/${state.worldId}/rollouts/${encodeURIComponent(id)}`;
  $("plot-link").href = `${base}/plot.png`;
  $("video-link").href = `${base}/video.mp4`;
  renderPlayer();
}

function play() {
  state.playing = !state.playing;
  $("play").textContent = state.playing ? "❚❚ pause" : "▶ play";
  let last = performance.now();
  const step = (now) => {
    if (!state.playing) return;
    const rollout = state.rollouts.get(state.current);
    if (now - last >= 1000 / rollout.fps) {
      last = now;
      state.frame = (state.frame + 1) % rollout.horizon_frames;
      renderPlayer();
    }
    requestAnimationFrame(step);
  };
  requestAnimationFrame(step);
}

// -- worlds --------------------------------------------------------------------------------
async function loadWorlds() {
  const { worlds } = await api("/v1/worlds");
  const list = $("world-list");
  list.replaceChildren(...worlds.map((w) => {
    const item = document.createElement("li");
    item.dataset.worldId = w.world_id;
    item.innerHTML = `<strong></strong><small></small>`;
    item.querySelector("strong").textContent = w.name;
    item.querySelector("small").textContent = `${w.object_count} objects, ${w.rollout_count} rollouts`;
    item.addEventListener("click", () => { location.hash = `world=${w.world_id}`; });
    if (w.world_id === state.worldId) item.classList.add("selected");
    return item;
  }));
  setStatus(worlds.length ? `${worlds.length} worlds` : "no worlds yet: POST one to /v1/worlds");
}

function fillObjects(summary) {
  const fmt = (v, d = 3) => (v === null || v === undefined ? "–" : Number(v).toFixed(d));
  $("objects").tBodies[0].replaceChildren(...summary.objects.map((o) => {
    const row = document.createElement("tr");
    const size = Object.entries(o.size).map(([k, v]) => `${k.replace("half_", "½")} ${fmt(v, 2)}`).join(", ");
    const cells = [o.object_id, `${o.color || ""} ${o.material || ""} ${o.shape}`, size, fmt(o.mass, 2), fmt(o.friction), fmt(o.restitution, 2),
      `frame ${o.entry_frame}`, o.initial_velocity.slice(0, 2).map((v) => fmt(v, 2)).join(", ")];
    cells.forEach((text, i) => {
      const cell = document.createElement("td");
      if (i === 1) { const swatch = document.createElement("span"); swatch.className = "swatch"; swatch.style.background = COLORS[o.color] || UNKNOWN_COLOR; cell.append(swatch); }
      cell.append(String(text));
      row.append(cell);
    });
    return row;
  }));
  $("fit-error").textContent = summary.fit_error ? `fit error: ${JSON.stringify(summary.fit_error)}` : "";
}

async function refreshRolloutIds() {
  const { rollouts } = await api(`/v1/worlds/${state.worldId}/rollouts`);
  state.rolloutIds = rollouts.map((r) => r.rollout_id);
  if (!state.rolloutIds.includes("base")) state.rolloutIds.unshift("base");
  for (const select of [$("rollout-select"), $("compare-a"), $("compare-b")]) {
    const keep = select.value;
    select.replaceChildren(...state.rolloutIds.map((id) => new Option(id, id)));
    if (state.rolloutIds.includes(keep)) select.value = keep;
  }
  $("rollout-ids").replaceChildren(...state.rolloutIds.map((id) => new Option(id, id)));
}

async function selectWorld(worldId) {
  try {
    setStatus(`loading ${worldId}…`);
    state.worldId = worldId; state.rollouts = new Map(); state.frame = 0; state.current = "base"; state.viewFor = null;
    document.querySelectorAll("#world-list li").forEach((li) => li.classList.toggle("selected", li.dataset.worldId === worldId));
    const [detail, summary] = await Promise.all([
      api(`/v1/worlds/${worldId}`),
      api(`/v1/worlds/${worldId}/tools/get_world_summary`, { method: "POST", headers: { "Content-Type": "application/json" }, body: "{}" }),
      loadRollout("base"),
    ]);
    state.world = detail.world; state.summary = summary;
    $("world").hidden = false;
    $("world-title").textContent = detail.name;
    $("world-facts").textContent = `${summary.object_count} objects · ${summary.fps} fps · ${summary.observed_frames} observed frames · horizon ${summary.default_horizon_frames} frames · world ${worldId}`;
    fillObjects(summary);
    await refreshRolloutIds();
    await showRollout("base");
    setStatus(`world ${detail.name} loaded`);
  } catch (error) {
    setStatus(error.message, true);
  }
}

// -- tools ---------------------------------------------------------------------------------
function fieldFor(name, schema, required) {
  const wrap = document.createElement("div");
  wrap.className = "field" + (required ? " required" : "");
  const labelEl = document.createElement("label");
  labelEl.textContent = name;
  labelEl.htmlFor = `arg-${name}`;
  let input;
  if (schema.enum) {
    input = document.createElement("select");
    if (!required) input.append(new Option("(default)", ""));
    schema.enum.forEach((v) => input.append(new Option(String(v), String(v))));
    input.dataset.kind = "enum";
  } else if (schema.type === "integer" || schema.type === "number") {
    input = document.createElement("input");
    input.type = "number"; input.step = schema.type === "integer" ? "1" : "any";
    if (schema.minimum !== undefined) input.min = schema.minimum;
    if (schema.maximum !== undefined) input.max = schema.maximum;
    input.dataset.kind = schema.type;
  } else if (schema.type === "boolean") {
    input = document.createElement("select");
    ["", "true", "false"].forEach((v) => input.append(new Option(v || "(default)", v)));
    input.dataset.kind = "json";
  } else if (schema.type === "string") {
    input = document.createElement("input"); input.type = "text"; input.dataset.kind = "string";
    if (ROLLOUT_ARGUMENTS.has(name)) input.setAttribute("list", "rollout-ids");
  } else {
    input = document.createElement("input"); input.type = "text"; input.dataset.kind = schema.type === "array" ? "array" : "json";
    input.placeholder = schema.type === "array" ? "e.g. [1, 2] or 1, 2" : "JSON, e.g. 2.0 or [1.0, 0.5, 0]";
  }
  input.id = `arg-${name}`; input.name = name;
  if (schema.default !== undefined) input.placeholder = `default ${JSON.stringify(schema.default)}`;
  const help = document.createElement("small");
  help.textContent = schema.description || "";
  wrap.append(labelEl, input, help);
  return wrap;
}

async function showTool(name) {
  const tool = await api(`/v1/tools/${name}`);
  $("tool-description").textContent = tool.description;
  const schema = tool.arguments_schema, required = new Set(schema.required || []);
  const fields = Object.entries(schema.properties || {}).map(([key, sub]) => fieldFor(key, sub, required.has(key)));
  $("tool-fields").replaceChildren(...fields);
}

function collectArguments() {
  const args = {};
  for (const input of $("tool-fields").querySelectorAll("input, select")) {
    const raw = input.value.trim();
    if (raw === "") continue;
    const kind = input.dataset.kind;
    if (kind === "integer" || kind === "number") args[input.name] = Number(raw);
    else if (kind === "string" || kind === "enum") args[input.name] = raw;
    else if (kind === "array" && !raw.startsWith("[")) args[input.name] = raw.split(",").map((s) => { const t = s.trim(); return isNaN(Number(t)) ? t : Number(t); });
    else {
      try { args[input.name] = JSON.parse(raw); } catch (e) { throw new Error(`${input.name}: not valid JSON`); }
    }
  }
  return args;
}

async function runTool(event) {
  event.preventDefault();
  const name = $("tool-select").value, out = $("tool-result");
  out.dataset.state = "running"; out.classList.remove("error");
  try {
    const args = collectArguments();
    const result = await api(`/v1/worlds/${state.worldId}/tools/${name}`, {
      method: "POST", headers: { "Content-Type": "application/json" }, body: JSON.stringify(args),
    });
    out.textContent = JSON.stringify(result, null, 2);
    out.dataset.state = "ok";
    if (result.rollout_id && result.rollout_id !== "base") {
      await refreshRolloutIds();
      await showRollout(result.rollout_id);
      $("compare-a").value = "base"; $("compare-b").value = result.rollout_id;
      const collisions = (result.collisions || []).length;
      $("tool-rollout").textContent = `made rollout ${result.rollout_id} (${collisions} collisions); it now plays above`;
      $("tool-rollout").dataset.rolloutId = result.rollout_id;
    }
    setStatus(`${name}: ok`);
    loadWorlds().catch(() => {});
  } catch (error) {
    out.textContent = JSON.stringify(error.body || { error: error.message }, null, 2);
    out.dataset.state = "error"; out.classList.add("error");
    setStatus(`${name}: ${error.message}`, true);
  }
}

// -- compare -------------------------------------------------------------------------------
async function runCompare() {
  try {
    const a = $("compare-a").value, b = $("compare-b").value;
    const [ra, rb, result] = await Promise.all([loadRollout(a), loadRollout(b), api(`/v1/worlds/${state.worldId}/tools/compare_rollouts`, {
      method: "POST", headers: { "Content-Type": "application/json" }, body: JSON.stringify({ reference_rollout_id: a, edited_rollout_id: b }),
    })]);
    const [flagsA, flagsB] = divergingEvents(ra.events, rb.events);
    const pairs = (list) => list.map((p) => p.join("-")).join(", ") || "none";
    $("compare-summary").textContent = `added collisions: ${pairs(result.added_pairs)} · removed: ${pairs(result.removed_pairs)}`;
    const horizon = Math.max(ra.horizon_frames, rb.horizon_frames);
    state.compare = { ra, rb, flagsA, flagsB, view: fitView([ra, rb], $("compare-canvas-a")), frame: horizon - 1 };
    $("compare-scrubber").max = horizon - 1; $("compare-scrubber").value = horizon - 1;
    $("compare-view").hidden = false;
    drawCompare();
  } catch (error) {
    setStatus(`compare: ${error.message}`, true);
  }
}

function drawCompare() {
  const c = state.compare;
  drawRollout($("compare-canvas-a"), c.ra, c.frame, c.view, label(c.ra), c.flagsA);
  drawRollout($("compare-canvas-b"), c.rb, c.frame, c.view, label(c.rb), c.flagsB);
  c.seek = drawTimeline($("compare-timeline"), [{ label: "reference", rollout: c.ra, flags: c.flagsA }, { label: "edited", rollout: c.rb, flags: c.flagsB }], c.frame);
}

// A plain link cannot send the bearer key: with a key set, fetch the picture and open it as a blob.
async function openWithKey(event) {
  if (!localStorage.getItem("physmind-api-key")) return;
  event.preventDefault();
  const tab = window.open("", "_blank");
  try {
    const response = await fetch(event.currentTarget.href, { headers: headers() });
    if (!response.ok) throw new Error(`${response.status} ${await response.text()}`);
    tab.location = URL.createObjectURL(await response.blob());
  } catch (error) {
    if (tab) tab.close();
    setStatus(`picture: ${error.message}`, true);
  }
}

// -- wiring --------------------------------------------------------------------------------
async function main() {
  $("api-key").value = localStorage.getItem("physmind-api-key") || "";
  $("api-key").addEventListener("change", (e) => { localStorage.setItem("physmind-api-key", e.target.value.trim()); start(); });
  $("scrubber").addEventListener("input", (e) => { state.frame = Number(e.target.value); renderPlayer(); });
  $("timeline").addEventListener("click", (e) => { if (state.seek) { state.frame = state.seek(e.offsetX * $("timeline").width / $("timeline").clientWidth); renderPlayer(); } });
  $("play").addEventListener("click", play);
  for (const link of [$("plot-link"), $("video-link")]) link.addEventListener("click", openWithKey);
  $("rollout-select").addEventListener("change", (e) => showRollout(e.target.value).catch((err) => setStatus(err.message, true)));
  $("tool-select").addEventListener("change", (e) => showTool(e.target.value).catch((err) => setStatus(err.message, true)));
  $("tool-form").addEventListener("submit", runTool);
  $("compare-run").addEventListener("click", runCompare);
  $("compare-scrubber").addEventListener("input", (e) => { if (state.compare) { state.compare.frame = Number(e.target.value); drawCompare(); } });
  $("compare-timeline").addEventListener("click", (e) => { if (state.compare && state.compare.seek) { state.compare.frame = state.compare.seek(e.offsetX); $("compare-scrubber").value = state.compare.frame; drawCompare(); } });
  const datalist = document.createElement("datalist"); datalist.id = "rollout-ids"; document.body.append(datalist);
  window.addEventListener("hashchange", route);
  await start();
}

async function start() {
  try {
    const { tools } = await api("/v1/tools");
    state.tools = tools.map((t) => t.function.name);
    $("tool-select").replaceChildren(...state.tools.map((n) => new Option(n, n)));
    $("tool-select").value = state.tools.includes("simulate_edit") ? "simulate_edit" : state.tools[0];
    await showTool($("tool-select").value);
    await loadWorlds();
    await route();
  } catch (error) {
    setStatus(error.message, true);
  }
}

async function route() {
  const match = /world=([\w-]+)/.exec(location.hash);
  if (match && match[1] !== state.worldId) await selectWorld(match[1]);
}

main();
