// uhrisim web viewer: top-down map (pMarineViewer-like), sonar fan, 3-D view, live plots.
// All positions arrive in NED metres (north, east, depth), headings in compass degrees.
// The page keeps its state in window.uhri (read by the tests and handy in the console).

const $ = (id) => document.getElementById(id);
// number → fixed text; "–" for null/undefined/NaN (the server sends non-finite as null)
const fmt = (v, digits) => (typeof v === "number" && isFinite(v) ? v.toFixed(digits) : "–");
const DEG = Math.PI / 180;
const PLOT_WINDOW = 60; // s of plot history shown
const TRAIL_MAX = 4000; // points per agent kept for live trails
const TRAIL_MIN_DT = 0.25; // s between live trail points
const TRACK_COLORS = { diver: "#3f3", track: "#f90", tentative: "#888" }; // sonar tracks

// tools by kind, loads and sites (map and 3-D view)
const TEAM_COLORS = { wrench: "#c0c8d0", hammer: "#b08a5a", light: "#fff3a0",
  lift_bag: "#ff9f1c", basket: "#9c7b4f", load: "#8a8f99", flange: "#6fa8dc",
  hatch: "#76b57b", other: "#d0d0d0" };
const teamColor = (kind) => TEAM_COLORS[kind] || TEAM_COLORS.other;
const KIND_COLORS = { rov: "#f5c518", diver: "#ff7a45", vehicle: "#4fd1ff" };
const EXTRA_COLORS = ["#9be564", "#d783ff", "#ff5c8a", "#5ce1e6", "#ffd6a5"];

const state = {
  connected: false,
  mode: "live",
  scene: null,
  buttons: [],
  frame: null,
  agents: {}, // name -> last agent record
  colors: {},
  trails: {}, // name -> [[t, n, e, d], ...]
  tracks: null, // replay: name -> {t:[], n:[], e:[], d:[]}
  replay: null,
  selected: null,
  sonar: {}, // "<agent>/<sensor>" -> {agent, sensor, t, fov_deg, max_range, img, marks}
  camera: {}, // "<agent>/<sensor>" -> {agent, sensor, t, img}
  camerasReceived: 0,
  team: null, // the frame's team entry (tools, sites, progress, diver figures), or null
  teamDrawn: null, // what the map drew of it (for tests)
  plots: { range: [], depth: {}, speed: {} },
  framesReceived: 0,
  sonarsReceived: 0,
  commandsSent: 0,
  // map centre (north, east), px per metre; how it was last fitted; whether the user moved it
  view: { cn: 0, ce: 0, scale: 10, fitted: "", userMoved: false },
  gl: false,
  errors: [],
};
window.uhri = state;

// ------------------------------------------------------------------ connection
let ws = null;
let retryDelay = 500;

function setConn(text, cls) {
  const el = $("conn");
  el.textContent = text;
  el.className = "conn " + cls;
}

function connect() {
  const proto = location.protocol === "https:" ? "wss:" : "ws:";
  setConn("connecting…", "conn-wait");
  ws = new WebSocket(`${proto}//${location.host}/ws`);
  ws.onopen = () => {
    retryDelay = 500;
    state.connected = true;
  };
  ws.onmessage = (ev) => {
    let msg;
    try {
      msg = JSON.parse(ev.data);
    } catch (e) {
      state.errors.push("bad JSON from server");
      return;
    }
    if (msg.type === "hello") onHello(msg);
    else if (msg.type === "frame") onFrame(msg);
    else if (msg.type === "sonar") onSonar(msg);
    else if (msg.type === "camera") onCamera(msg);
  };
  ws.onclose = () => {
    state.connected = false;
    const secs = (retryDelay / 1000).toFixed(1);
    setConn(`disconnected — retrying in ${secs} s`, "conn-bad");
    setTimeout(connect, retryDelay);
    retryDelay = Math.min(retryDelay * 2, 5000);
  };
}

function send(obj) {
  if (ws && ws.readyState === WebSocket.OPEN) {
    ws.send(JSON.stringify(obj));
    state.commandsSent += 1;
    return true;
  }
  return false;
}

function command(kind, extra = {}) {
  return send({ type: "command", kind, agent: null, name: null, value: null, ...extra });
}

// ------------------------------------------------------------------ messages
function agentColor(name, kind) {
  if (!state.colors[name]) {
    const used = Object.values(state.colors);
    let c = KIND_COLORS[kind] || KIND_COLORS.vehicle;
    if (used.includes(c)) c = EXTRA_COLORS[used.length % EXTRA_COLORS.length];
    state.colors[name] = c;
  }
  return state.colors[name];
}

function onHello(msg) {
  state.mode = msg.mode;
  state.scene = msg.scene || { objects: [] };
  state.buttons = msg.buttons || [];
  state.replay = msg.replay || null;
  state.tracks = msg.tracks || null;
  state.trails = {};
  for (const [name, pts] of Object.entries(msg.history || {})) state.trails[name] = pts.slice();
  setConn(msg.mode === "replay" ? "replay" : "live", "conn-ok");
  buildButtons();
  $("replay-group").classList.toggle("hidden", msg.mode !== "replay");
  if (state.replay) {
    const s = $("slider");
    s.min = state.replay.t_start;
    s.max = state.replay.t_end;
    s.step = Math.max((state.replay.t_end - state.replay.t_start) / 2000, 0.001);
    $("replay-end").textContent = `/ ${state.replay.t_end.toFixed(1)} s`;
  }
  if (!state.view.fitted) fitView();
  view3d.setScene(state.scene);
  dirty.map = dirty.plots = true;
}

function onFrame(f) {
  const prevT = state.frame ? state.frame.t : -Infinity;
  if (f.t < prevT) resetHistories(); // replay seek or a new run
  state.frame = f;
  state.framesReceived += 1;
  for (const a of f.agents || []) {
    state.agents[a.name] = a;
    agentColor(a.name, a.kind);
    if (state.mode !== "replay") {
      const tr = state.trails[a.name] || (state.trails[a.name] = []);
      const last = tr[tr.length - 1];
      if (!last || f.t - last[0] >= TRAIL_MIN_DT) {
        tr.push([f.t, a.north, a.east, a.depth]);
        if (tr.length > TRAIL_MAX) tr.splice(0, tr.length - TRAIL_MAX);
      }
    }
  }
  if (!state.selected && f.agents && f.agents.length) {
    const rov = f.agents.find((a) => a.kind === "rov") || f.agents[0];
    state.selected = rov.name;
  }
  // fit on the first frames (agents and overlays arrive with them) until the user pans/zooms
  if (!state.view.userMoved && !drag && (state.view.fitted !== "agents" || state.framesReceived <= 3)) {
    fitView();
  }
  state.team = f.team || null;
  const tm = state.team;
  if (tm && (Object.keys(tm.progress || {}).length || (tm.sites || []).length || (tm.log || []).length)) {
    updateTeamPanel(tm);
  }
  pushPlots(f, f.jump || state.seeking);
  state.seeking = false;
  updateBar(f);
  dirty.map = dirty.plots = dirty.view3d = true;
}

function onSonar(s) {
  state.sonarsReceived += 1;
  const img = new Image();
  img.onload = () => {
    state.sonar[`${s.agent}/${s.sensor}`] = { agent: s.agent, sensor: s.sensor, t: s.t,
      fov_deg: s.fov_deg, max_range: s.max_range, img, marks: s.marks || [] };
    dirty.sonar = dirty.view3d = true;
  };
  img.src = "data:image/png;base64," + s.fan_png_b64;
}

function onCamera(m) {
  state.camerasReceived += 1;
  const img = new Image();
  img.onload = () => {
    state.camera[`${m.agent}/${m.sensor}`] = { agent: m.agent, sensor: m.sensor, t: m.t, img };
    $("camera-panel").classList.remove("hidden");
    dirty.camera = true;
  };
  img.src = "data:image/png;base64," + m.png_b64;
}

function resetHistories() {
  state.plots = { range: [], depth: {}, speed: {} };
  if (state.mode !== "replay") state.trails = {};
}

// A frame that jumps in time (a replay seek: f.jump, or one the page asked for) starts new plot segments: a null
// sample marks the gap, so the line is not drawn across time that was skipped.
function pushPlots(f, jump) {
  const p = f.plots || {};
  const t = f.t;
  const cut = (arr) => {
    while (arr.length && arr[0][0] < t - PLOT_WINDOW) arr.shift();
  };
  const add = (arr, v) => {
    if (jump && arr.length) arr.push([t, null]);
    arr.push([t, v]);
    cut(arr);
  };
  if (p.range_to_diver !== undefined && p.range_to_diver !== null) add(state.plots.range, p.range_to_diver);
  else cut(state.plots.range);
  for (const key of ["depth", "speed"]) {
    for (const [name, v] of Object.entries(p[key] || {})) {
      if (v === null) continue;
      add(state.plots[key][name] || (state.plots[key][name] = []), v);
    }
  }
}

// The task panel: each diver's orders done / total and what it does now, every site's
// state, who holds what, the latest teamwork and order events.
function updateTeamPanel(team) {
  $("team-panel").classList.remove("hidden");
  const box = $("team");
  box.textContent = "";
  const add = (cls, text, parent = box) => {
    const el = document.createElement("div");
    el.className = cls;
    el.textContent = text;
    parent.appendChild(el);
    return el;
  };
  for (const [name, p] of Object.entries(team.progress || {})) {
    const d = add("diver", "");
    d.dataset.diver = name;
    const total = p.total === null || p.total === undefined ? "?" : p.total;
    const failed = p.failed ? " · FAILED" : "";
    add("count", `${name}: ${p.done}/${total} orders done${failed}`, d);
    const bar = add("bar", "", d);
    const fill = document.createElement("div");
    fill.style.width = `${p.total ? Math.min(100, (100 * p.done) / p.total) : 0}%`;
    bar.appendChild(fill);
    const now = p.current ? `now: ${p.current}` : p.last ? `last: ${p.last}` : "no order";
    add("current", now, d);
  }
  for (const site of team.sites || []) add("site", `${site.name}: ${site.text}`);
  for (const o of team.objects || []) {
    if (o.held_by && o.held_by.length) add("site", `${o.name} held by ${o.held_by.join(" + ")}`);
  }
  for (const ev of (team.log || []).slice(-4)) add("log", `${fmt(ev.t, 1)} s ${ev.text.replace(/^t=[\d.]+ s /, "")}`);
  const n = Object.keys(team.progress || {}).length;
  $("team-caption").textContent = n ? `${n} diver${n > 1 ? "s" : ""}` : "";
}

let sliderDragging = false;
function updateBar(f) {
  $("clock").textContent = `t = ${fmt(f.t, 1)} s`;
  const rtf = fmt(f.rtf, 2);
  $("rtf").textContent = `RTF ${rtf}`;
  $("btn-pause").textContent = f.paused ? "Resume" : "Pause";
  // show the run's speed (null = infinite = "max") unless the user is choosing one
  const sel = $("speed");
  if (document.activeElement !== sel && f.speed_factor !== undefined) {
    const want = f.speed_factor === null ? "max" : String(f.speed_factor);
    if ([...sel.options].some((o) => o.value === want)) sel.value = want;
  }
  $("btn-step").disabled = !f.paused;
  if (state.mode === "replay" && !sliderDragging) $("slider").value = f.t;
}

// ------------------------------------------------------------------ controls
function buildButtons() {
  const box = $("buttons");
  box.textContent = "";
  for (const b of state.buttons) {
    const el = document.createElement("button");
    el.type = "button";
    el.className = "post";
    el.textContent = b.label;
    el.dataset.var = b.var;
    el.dataset.agent = b.agent;
    el.title = `post ${b.var}=${b.value} to ${b.agent}`;
    el.onclick = () => command("post", { agent: b.agent, name: b.var, value: b.value });
    box.appendChild(el);
  }
}

function togglePause() {
  const paused = state.frame ? state.frame.paused : false;
  command(paused ? "resume" : "pause");
}

$("btn-pause").onclick = togglePause;
$("btn-step").onclick = () => command("step", { value: 1 });
$("speed").onchange = (ev) => {
  const v = ev.target.value;
  command("speed", { value: v === "max" ? "max" : parseFloat(v) });
};
$("slider").addEventListener("input", (ev) => {
  sliderDragging = true;
  if (send({ type: "seek", t: parseFloat(ev.target.value) })) state.seeking = true;
});
$("slider").addEventListener("change", () => {
  sliderDragging = false;
});
window.addEventListener("keydown", (ev) => {
  if (ev.target.tagName === "INPUT" || ev.target.tagName === "SELECT") return;
  if (ev.key === " ") {
    togglePause();
    ev.preventDefault();
  } else if (ev.key === "s") command("step", { value: 1 });
  else if (ev.key === "f") fitView();
});

// ------------------------------------------------------------------ canvases
const dirty = { map: true, sonar: true, camera: true, plots: true, view3d: true };
state.redraw = () => {
  dirty.map = dirty.sonar = dirty.camera = dirty.plots = dirty.view3d = true;
};

function sizeCanvas(c) {
  const dpr = window.devicePixelRatio || 1;
  const w = Math.max(1, Math.round(c.clientWidth * dpr));
  const h = Math.max(1, Math.round(c.clientHeight * dpr));
  if (c.width !== w || c.height !== h) {
    c.width = w;
    c.height = h;
  }
  return dpr;
}

// ---------- map (north up, east right)
const mapCanvas = $("map");

function worldToScreen(n, e) {
  const v = state.view;
  const w = mapCanvas.clientWidth;
  const h = mapCanvas.clientHeight;
  return [w / 2 + (e - v.ce) * v.scale, h / 2 - (n - v.cn) * v.scale];
}
function screenToWorld(x, y) {
  const v = state.view;
  const w = mapCanvas.clientWidth;
  const h = mapCanvas.clientHeight;
  return [v.cn - (y - h / 2) / v.scale, v.ce + (x - w / 2) / v.scale];
}
state.worldToScreen = worldToScreen; // for tests: CSS pixels inside the map canvas

// Fit the map to what matters: agents, their tracks and polygons (40 m at least);
// the scene's bounds only until agents are known. view.fitted: "" | "bounds" | "agents".
function fitView() {
  let nmin = Infinity, nmax = -Infinity, emin = Infinity, emax = -Infinity;
  const add = (n, e) => {
    nmin = Math.min(nmin, n); nmax = Math.max(nmax, n);
    emin = Math.min(emin, e); emax = Math.max(emax, e);
  };
  for (const a of Object.values(state.agents)) add(a.north, a.east);
  if (state.tracks) {
    for (const tr of Object.values(state.tracks)) {
      for (let i = 0; i < tr.n.length; i += 10) add(tr.n[i], tr.e[i]);
    }
  }
  const ov = state.frame && state.frame.overlays;
  for (const poly of (ov && ov.polygons) || []) for (const p of poly.points) add(p[0], p[1]);
  let what = "agents", minSpan = 40;
  if (!isFinite(nmin)) {
    const b = state.scene && state.scene.bounds;
    if (!b) return;
    add(b[0][0], b[0][1]); add(b[1][0], b[1][1]);
    what = "bounds";
    minSpan = 10;
  }
  const w = mapCanvas.clientWidth || 800, h = mapCanvas.clientHeight || 600;
  const span = Math.max(nmax - nmin, emax - emin, minSpan) * 1.15;
  state.view.cn = (nmin + nmax) / 2;
  state.view.ce = (emin + emax) / 2;
  state.view.scale = Math.min(w, h) / span;
  state.view.fitted = what;
  dirty.map = true;
}

let drag = null;
mapCanvas.addEventListener("mousedown", (ev) => {
  drag = { x: ev.offsetX, y: ev.offsetY, cn: state.view.cn, ce: state.view.ce, moved: false };
});
window.addEventListener("mousemove", (ev) => {
  if (!drag) return;
  const r = mapCanvas.getBoundingClientRect();
  const dx = ev.clientX - r.left - drag.x, dy = ev.clientY - r.top - drag.y;
  if (Math.abs(dx) + Math.abs(dy) > 3) drag.moved = state.view.userMoved = true;
  state.view.ce = drag.ce - dx / state.view.scale;
  state.view.cn = drag.cn + dy / state.view.scale;
  dirty.map = true;
});
window.addEventListener("mouseup", (ev) => {
  if (drag && !drag.moved) pickAgent(ev);
  drag = null;
});
mapCanvas.addEventListener("wheel", (ev) => {
  ev.preventDefault();
  const [n, e] = screenToWorld(ev.offsetX, ev.offsetY);
  const k = Math.exp(-ev.deltaY * 0.0015);
  state.view.scale = Math.min(Math.max(state.view.scale * k, 0.05), 2000);
  state.view.userMoved = true;
  const [n2, e2] = screenToWorld(ev.offsetX, ev.offsetY);
  state.view.cn += n - n2;
  state.view.ce += e - e2;
  dirty.map = true;
}, { passive: false });
mapCanvas.addEventListener("dblclick", fitView);

function pickAgent(ev) {
  const r = mapCanvas.getBoundingClientRect();
  const x = ev.clientX - r.left, y = ev.clientY - r.top;
  let best = null, bestD = 18;
  for (const a of Object.values(state.agents)) {
    const [sx, sy] = worldToScreen(a.north, a.east);
    const d = Math.hypot(sx - x, sy - y);
    if (d < bestD) { best = a.name; bestD = d; }
  }
  if (best) {
    state.selected = best;
    command("select", { agent: best });
    dirty.map = dirty.sonar = dirty.camera = dirty.view3d = true;
  }
}

function niceStep(x) {
  const p = Math.pow(10, Math.floor(Math.log10(x)));
  for (const m of [1, 2, 5, 10]) if (m * p >= x) return m * p;
  return 10 * p;
}

// Vehicle outlines in body units (forward = -y on screen before rotation), length 1.
const SHAPES = {
  rov: [[0, -0.5], [0.35, -0.3], [0.4, 0.5], [-0.4, 0.5], [-0.35, -0.3]],
  diver: [[0, -0.5], [0.18, -0.3], [0.12, 0.1], [0.3, 0.5], [0, 0.3], [-0.3, 0.5], [-0.12, 0.1], [-0.18, -0.3]],
  vehicle: [[0, -0.5], [0.25, 0.5], [0, 0.3], [-0.25, 0.5]],
};
const REAL_LENGTH = { rov: 0.37, diver: 1.8, vehicle: 4.0 };

function drawMap() {
  const c = mapCanvas;
  const dpr = sizeCanvas(c);
  const ctx = c.getContext("2d");
  ctx.setTransform(dpr, 0, 0, dpr, 0, 0);
  const w = c.clientWidth, h = c.clientHeight;
  ctx.fillStyle = "#0a2a44";
  ctx.fillRect(0, 0, w, h);

  // grid (hash marks in metres)
  const step = niceStep(80 / state.view.scale);
  const [nTop, eLeft] = screenToWorld(0, 0);
  const [nBot, eRight] = screenToWorld(w, h);
  ctx.strokeStyle = "rgba(120,170,210,0.12)";
  ctx.lineWidth = 1;
  ctx.beginPath();
  for (let e = Math.ceil(eLeft / step) * step; e <= eRight; e += step) {
    const [x] = worldToScreen(0, e);
    ctx.moveTo(x, 0); ctx.lineTo(x, h);
  }
  for (let n = Math.ceil(nBot / step) * step; n <= nTop; n += step) {
    const [, y] = worldToScreen(n, 0);
    ctx.moveTo(0, y); ctx.lineTo(w, y);
  }
  ctx.stroke();

  // static scene footprint (objects as small squares, labels)
  if (state.scene) {
    ctx.fillStyle = "rgba(190,170,130,0.55)";
    for (const o of state.scene.objects || []) {
      if (!o.position_ned) continue;
      const [x, y] = worldToScreen(o.position_ned[0], o.position_ned[1]);
      const r = Math.max(2, objRadius(o) * state.view.scale);
      ctx.beginPath();
      ctx.arc(x, y, r, 0, 2 * Math.PI);
      ctx.fill();
    }
  }

  const f = state.frame;
  const ov = (f && f.overlays) || {};
  const queued = []; // secondary labels, placed after the vehicles' so they give way
  // polygons (loiter etc.)
  for (const poly of ov.polygons || []) {
    if (!poly.points || poly.points.length < 2) continue;
    ctx.strokeStyle = "#e8e8e8";
    ctx.setLineDash([]);
    ctx.lineWidth = 1.2;
    ctx.beginPath();
    poly.points.forEach((p, i) => {
      const [x, y] = worldToScreen(p[0], p[1]);
      if (i === 0) ctx.moveTo(x, y); else ctx.lineTo(x, y);
    });
    ctx.closePath();
    ctx.stroke();
    ctx.fillStyle = "#e8e8e8";
    for (const p of poly.points) {
      const [x, y] = worldToScreen(p[0], p[1]);
      ctx.fillRect(x - 2, y - 2, 4, 4);
    }
    if (poly.label) {
      const [x, y] = worldToScreen(poly.points[0][0], poly.points[0][1]);
      queued.push({ text: poly.label, ax: x, ay: y, gap: 4, color: "#bbb" });
    }
  }
  // trails
  const tNow = f ? f.t : Infinity;
  for (const [name, tr] of Object.entries(trailsFor(tNow))) {
    ctx.fillStyle = state.colors[name] || "#ccc";
    ctx.globalAlpha = 0.7;
    for (const p of tr) {
      const [x, y] = worldToScreen(p[1], p[2]);
      ctx.fillRect(x - 1.5, y - 1.5, 3, 3);
    }
    ctx.globalAlpha = 1;
  }
  // circles around agents (contact / alert ranges)
  for (const cir of ov.circles || []) {
    const a = state.agents[cir.agent];
    if (!a || !(cir.radius > 0)) continue;
    const [x, y] = worldToScreen(a.north, a.east);
    ctx.strokeStyle = state.colors[cir.agent] || "#aaa";
    ctx.globalAlpha = 0.6;
    ctx.setLineDash([6, 4]);
    ctx.beginPath();
    ctx.arc(x, y, cir.radius * state.view.scale, 0, 2 * Math.PI);
    ctx.stroke();
    ctx.setLineDash([]);
    ctx.globalAlpha = 1;
    if (cir.label) queued.push({ text: cir.label, ax: x + cir.radius * state.view.scale * 0.71,
      ay: y - cir.radius * state.view.scale * 0.71, gap: 3, color: "#999" });
  }
  // sonar perception tracks: green the diver track, orange other confirmed, grey tentative
  for (const tr of ov.tracks || []) {
    const [x, y] = worldToScreen(tr.north, tr.east);
    ctx.strokeStyle = TRACK_COLORS[tr.kind] || "#888";
    ctx.lineWidth = tr.kind === "diver" ? 2 : 1;
    ctx.beginPath();
    ctx.arc(x, y, 6, 0, 2 * Math.PI);
    ctx.stroke();
    if (tr.kind !== "tentative") {
      queued.push({ text: `T${tr.id}`, ax: x, ay: y, gap: 8, color: TRACK_COLORS[tr.kind] });
    }
  }
  // points (trail point, waypoints)
  for (const pt of ov.points || []) {
    const [x, y] = worldToScreen(pt.north, pt.east);
    ctx.strokeStyle = state.colors[pt.agent] || "#fff";
    ctx.lineWidth = 1.5;
    ctx.beginPath();
    ctx.moveTo(x - 5, y - 5); ctx.lineTo(x + 5, y + 5);
    ctx.moveTo(x + 5, y - 5); ctx.lineTo(x - 5, y + 5);
    ctx.stroke();
    if (pt.label) queued.push({ text: pt.label, ax: x, ay: y, gap: 6, color: "#aaa" });
  }
  state.teamDrawn = state.team ? drawTeam(ctx, state.team, queued) : null;
  // labels: the vehicles' first, then the rest; each at the first spot around its
  // anchor that covers no label and no vehicle placed before it (a leader line when the
  // spot is away from the anchor)
  const agents = Object.values(state.agents);
  const size = (a) => Math.max(REAL_LENGTH[SHAPES[a.kind] ? a.kind : "vehicle"] * state.view.scale, 18);
  const obstacles = agents.map((a) => {
    const [x, y] = worldToScreen(a.north, a.east);
    const r = size(a) / 2;
    return { x: x - r, y: y - r, w: 2 * r, h: 2 * r };
  });
  const labels = agents.map((a) => {
    const [x, y] = worldToScreen(a.north, a.east);
    const mode = a.mode ? ` ${a.mode}` : "";
    return { text: `${a.name}  d=${fmt(a.depth, 1)} m${mode}`, ax: x, ay: y,
      gap: size(a) / 2 + 3, color: state.colors[a.name] || "#fff" };
  });
  for (const o of (state.teamDrawn && state.teamDrawn.objects) || []) {
    obstacles.push({ x: o.x - 8, y: o.y - 8, w: 16, h: 16 }); // a tool's diamond and ring
  }
  state.labelBoxes = placeLabels(ctx, [...labels, ...queued], obstacles, { w, h });
  for (const a of agents) {
    const [x, y] = worldToScreen(a.north, a.east);
    const kind = SHAPES[a.kind] ? a.kind : "vehicle";
    const len = size(a);
    ctx.save();
    ctx.translate(x, y);
    ctx.rotate(a.heading_deg * DEG);
    ctx.scale(len, len);
    ctx.beginPath();
    SHAPES[kind].forEach((p, i) => (i === 0 ? ctx.moveTo(p[0], p[1]) : ctx.lineTo(p[0], p[1])));
    ctx.closePath();
    ctx.fillStyle = state.colors[a.name] || "#fff";
    ctx.fill();
    ctx.lineWidth = (a.name === state.selected ? 2.5 : 1) / len;
    ctx.strokeStyle = a.name === state.selected ? "#ffffff" : "#000000";
    ctx.stroke();
    ctx.restore();
  }
  // the divers' posed figures over their glyphs
  ctx.strokeStyle = "#ffffff";
  ctx.lineWidth = 1.5;
  for (const fig of figuresOnTop) {
    ctx.beginPath();
    for (const [i, j] of fig.bones) {
      const [x1, y1] = worldToScreen(fig.points[i][0], fig.points[i][1]);
      const [x2, y2] = worldToScreen(fig.points[j][0], fig.points[j][1]);
      ctx.moveTo(x1, y1); ctx.lineTo(x2, y2);
    }
    ctx.stroke();
  }
  figuresOnTop = [];
  // scale bar
  const barM = niceStep(120 / state.view.scale);
  const barPx = barM * state.view.scale;
  ctx.strokeStyle = "#fff";
  ctx.lineWidth = 2;
  ctx.beginPath();
  ctx.moveTo(16, h - 18); ctx.lineTo(16 + barPx, h - 18);
  ctx.moveTo(16, h - 23); ctx.lineTo(16, h - 13);
  ctx.moveTo(16 + barPx, h - 23); ctx.lineTo(16 + barPx, h - 13);
  ctx.stroke();
  label(ctx, `${barM} m`, 16 + barPx / 2 - 10, h - 26, "#fff");
  // north arrow
  ctx.fillStyle = "#fff";
  ctx.beginPath();
  ctx.moveTo(w - 24, 28); ctx.lineTo(w - 30, 44); ctx.lineTo(w - 18, 44);
  ctx.closePath();
  ctx.fill();
  label(ctx, "N", w - 28, 58, "#fff");
}

// Tools and loads (diamonds; ringed when held), sites (squares with their state as
// label) and the divers' posed figures (stick figures over the glyph); returns what
// was drawn: {objects: [{name, x, y}], sites: [{name, x, y}], figures: {name: bones}}.
function drawTeam(ctx, team, queued) {
  const out = { objects: [], sites: [], figures: {} };
  for (const site of team.sites || []) {
    if (site.kind === "lift_bag" && !(site.litres > 0) && !site.attached_to) continue;
    const [x, y] = worldToScreen(site.north, site.east);
    ctx.strokeStyle = teamColor(site.kind);
    ctx.lineWidth = 2;
    const r = site.kind === "lift_bag" ? 4 + 6 * Math.min(1, site.litres / site.capacity_litres) : 6;
    ctx.strokeRect(x - r, y - r, 2 * r, 2 * r);
    queued.push({ text: `${site.name}: ${site.text}`, ax: x, ay: y, gap: r + 3,
      color: teamColor(site.kind) });
    out.sites.push({ name: site.name, x, y });
  }
  for (const o of team.objects || []) {
    const [x, y] = worldToScreen(o.north, o.east);
    ctx.fillStyle = teamColor(o.kind);
    ctx.beginPath();
    ctx.moveTo(x, y - 5); ctx.lineTo(x + 5, y); ctx.lineTo(x, y + 5); ctx.lineTo(x - 5, y);
    ctx.closePath();
    ctx.fill();
    const held = o.held_by && o.held_by.length;
    if (held) {
      ctx.strokeStyle = "#fff";
      ctx.lineWidth = 1.5;
      ctx.beginPath();
      ctx.arc(x, y, 8, 0, 2 * Math.PI);
      ctx.stroke();
    }
    const isSite = (team.sites || []).some((site) => site.name === o.name);
    if (!held && !isSite) queued.push({ text: o.name, ax: x, ay: y, gap: 9, color: teamColor(o.kind) });
    out.objects.push({ name: o.name, x, y });
  }
  for (const [name, fig] of Object.entries(team.figures || {})) {
    out.figures[name] = fig.bones.length;
    figuresOnTop.push(fig);
  }
  return out;
}
let figuresOnTop = []; // stroked after the vehicles' glyphs

const LABEL_H = 14; // px: a 12 px label's box
const overlaps = (a, b) => a.x < b.x + b.w && b.x < a.x + a.w && a.y < b.y + b.h && b.y < a.y + a.h;

// Place labels {text, ax, ay (anchor, px), gap (px from the anchor), color} in order:
// each takes the first of eight spots around its anchor, at growing distance, whose box
// meets no box taken before and no obstacle and lies inside `bounds` {w, h}; returns the
// boxes {text, x, y, w, h, ax, ay} (y: top) after drawing them.
function placeLabels(ctx, items, obstacles, bounds) {
  ctx.font = "12px system-ui, 'DejaVu Sans', sans-serif";
  const taken = [];
  const boxes = [];
  for (const l of items) {
    const w = ctx.measureText(l.text).width + 2, h = LABEL_H;
    let best = null;
    for (let ring = 0; ring < 6 && !best; ring++) {
      const g = l.gap + ring * 12;
      const spots = [[g, -h / 2], [g, g * 0.3], [g, -h - g * 0.3], [-w - g, -h / 2],
        [-w / 2, -h - g], [-w / 2, g], [-w - g, g * 0.3], [-w - g, -h - g * 0.3]];
      for (const [dx, dy] of spots) {
        const box = { x: l.ax + dx, y: l.ay + dy, w, h };
        const inside = box.x >= 0 && box.y >= 0 && box.x + w <= bounds.w && box.y + h <= bounds.h;
        if (inside && !taken.some((b) => overlaps(box, b)) && !obstacles.some((b) => overlaps(box, b))) {
          best = box;
          break;
        }
      }
    }
    if (!best) best = { x: l.ax + l.gap, y: l.ay - h / 2, w, h }; // crowded: at its anchor
    taken.push(best);
    if (Math.hypot(best.x + (best.x < l.ax ? w : 0) - l.ax, best.y + h / 2 - l.ay) > l.gap + 14) {
      ctx.strokeStyle = l.color;
      ctx.globalAlpha = 0.5;
      ctx.lineWidth = 1;
      ctx.beginPath();
      ctx.moveTo(l.ax, l.ay);
      ctx.lineTo(best.x < l.ax ? best.x + w : best.x, best.y + h / 2);
      ctx.stroke();
      ctx.globalAlpha = 1;
    }
    label(ctx, l.text, best.x + 1, best.y + 11, l.color);
    boxes.push({ text: l.text, ...best, ax: l.ax, ay: l.ay });
  }
  return boxes;
}

function label(ctx, text, x, y, color) {
  ctx.font = "12px system-ui, 'DejaVu Sans', sans-serif";
  ctx.fillStyle = "rgba(0,0,0,0.55)";
  ctx.fillText(text, x + 1, y + 1);
  ctx.fillStyle = color;
  ctx.fillText(text, x, y);
}

function objRadius(o) {
  if (o.radius) return o.radius;
  if (Array.isArray(o.size)) return Math.max(o.size[0], o.size[1] || 0) / 2;
  if (typeof o.size === "number") return o.size / 2;
  return 0.5;
}

// Trail points to draw at time t: replay uses the recorded track up to t.
function trailsFor(t) {
  if (state.mode !== "replay" || !state.tracks) return state.trails;
  const out = {};
  for (const [name, tr] of Object.entries(state.tracks)) {
    let lo = 0, hi = tr.t.length;
    while (lo < hi) { const mid = (lo + hi) >> 1; if (tr.t[mid] <= t) lo = mid + 1; else hi = mid; }
    const pts = [];
    for (let i = 0; i < lo; i++) pts.push([tr.t[i], tr.n[i], tr.e[i], tr.d[i]]);
    out[name] = pts;
  }
  return out;
}

// ---------- image panels: the latest image of each sensor of the selected agent (or of
// the first agent that has one), side by side, each letterboxed on black; returns where
// each was drawn (empty when there is none yet)
function sensorsShown(images) {
  const keys = Object.keys(images).sort();
  const agent = keys.some((k) => images[k].agent === state.selected)
    ? state.selected : (keys.length ? images[keys[0]].agent : null);
  return keys.filter((k) => images[k].agent === agent);
}

function drawLatestImages(canvasId, images, zoom = 1) {
  const c = $(canvasId);
  const dpr = sizeCanvas(c);
  const ctx = c.getContext("2d");
  ctx.setTransform(dpr, 0, 0, dpr, 0, 0);
  const w = c.clientWidth, h = c.clientHeight;
  ctx.fillStyle = "#000";
  ctx.fillRect(0, 0, w, h);
  const keys = sensorsShown(images);
  const tw = w / Math.max(1, keys.length);
  const drawn = keys.map((key, i) => {
    const s = images[key];
    const tile = { x: i * tw, y: 0, w: tw, h };
    const k = Math.min(tw / s.img.width, h / s.img.height);
    // zoomed about the bottom centre of the picture (a sonar fan's apex)
    const dw = s.img.width * k * zoom, dh = s.img.height * k * zoom;
    const ax = i * tw + tw / 2, ay = (h + s.img.height * k) / 2;
    ctx.save();
    ctx.beginPath();
    ctx.rect(tile.x, tile.y, tile.w, tile.h);
    ctx.clip();
    ctx.imageSmoothingEnabled = true;
    ctx.drawImage(s.img, ax - dw / 2, ay - dh, dw, dh);
    ctx.restore();
    return { key, s, tile, ax, ay, dw, dh };
  });
  return { ctx, drawn };
}

// ---------- sonar panel
// Zoom: the wheel over the panel shows the near part of the fan (range / zoom), the apex
// fixed at the bottom centre; double-click shows the whole fan again.
const SONAR_ZOOM_MAX = 8;
state.sonarZoom = 1;
// key -> {shown_range (m), px_per_m, apex [x, y] (CSS px), arcs: [m], bearings: [deg]}
state.sonarView = {};
$("sonar").addEventListener("wheel", (ev) => {
  ev.preventDefault();
  state.sonarZoom = Math.min(Math.max(state.sonarZoom * Math.exp(-ev.deltaY * 0.0015), 1),
    SONAR_ZOOM_MAX);
  dirty.sonar = true;
}, { passive: false });
$("sonar").addEventListener("dblclick", () => { state.sonarZoom = 1; dirty.sonar = true; });

function drawSonar() {
  const { ctx, drawn } = drawLatestImages("sonar", state.sonar, state.sonarZoom);
  if (!drawn.length) {
    label(ctx, "no sonar image yet", 10, 20, "#777");
    $("sonar-caption").textContent = "";
    return;
  }
  state.sonarView = {};
  for (const d of drawn) state.sonarView[d.key] = drawFanOverlay(ctx, d);
  const zoom = state.sonarZoom > 1.01 ? ` · ×${state.sonarZoom.toFixed(1)}` : "";
  $("sonar-caption").textContent = drawn.map(({ key, s }) =>
    `${key} · t=${fmt(s.t, 1)} s · ${fmt(s.fov_deg, 0)}° · ${fmt(s.max_range, Number.isInteger(s.max_range) ? 0 : 1)} m`).join("  |  ") + zoom;
}

// Range arcs (nice steps, labelled in m), bearing rays (labelled in degrees, > 0 to
// starboard) and perception tracks on one fan drawn with its apex at (ax, ay), dh px
// for its full range times the zoom; returns what was drawn (for tests).
function drawFanOverlay(ctx, { s, tile, ax, ay, dh }) {
  const out = { shown_range: 0, px_per_m: 0, apex: [ax, ay], arcs: [], bearings: [] };
  if (!(s.max_range > 0)) return out;
  const pxPerM = dh / s.max_range;
  const shown = s.max_range / state.sonarZoom;
  out.shown_range = shown;
  out.px_per_m = pxPerM;
  ctx.save();
  ctx.beginPath();
  ctx.rect(tile.x, tile.y, tile.w, tile.h);
  ctx.clip();
  ctx.font = "10px system-ui, sans-serif";
  if (s.fov_deg > 0 && s.fov_deg < 180) {
    const half = (s.fov_deg * DEG) / 2;
    const step = niceStep(shown / 5);
    ctx.strokeStyle = "rgba(120,220,255,0.35)";
    ctx.lineWidth = 1;
    const digits = Math.max(0, -Math.floor(Math.log10(step) + 1e-9));
    for (let k = 1; k * step <= shown + 1e-9; k++) {
      const r = k * step, rp = r * pxPerM;
      ctx.beginPath();
      ctx.arc(ax, ay, rp, -Math.PI / 2 - half, -Math.PI / 2 + half);
      ctx.stroke();
      ctx.fillStyle = "rgba(160,230,255,0.85)";
      ctx.fillText(`${r.toFixed(digits)} m`, ax + rp * Math.sin(half) + 3, ay - rp * Math.cos(half));
      out.arcs.push(Number(r.toFixed(digits)));
    }
    // bearing rays every 5, 10, 15, 30 or 45 degrees (at most 8, labels 34 px apart at
    // least), labelled just inside the far edge
    const far = Math.min(shown * pxPerM, ay - tile.y - 4);
    const bStep = [5, 10, 15, 30].find((b) => s.fov_deg / b <= 8 && far * b * DEG >= 34) || 45;
    ctx.textAlign = "center";
    for (let b = -Math.floor(s.fov_deg / 2 / bStep) * bStep; b <= s.fov_deg / 2 + 1e-9; b += bStep) {
      const rad = b * DEG;
      ctx.strokeStyle = "rgba(120,220,255,0.22)";
      ctx.beginPath();
      ctx.moveTo(ax, ay);
      ctx.lineTo(ax + far * Math.sin(rad), ay - far * Math.cos(rad));
      ctx.stroke();
      ctx.fillStyle = "rgba(160,230,255,0.85)";
      const text = b === 0 ? "0°" : `${b > 0 ? "+" : "−"}${Math.abs(b)}°`;
      ctx.fillText(text, ax + (far - 6) * Math.sin(rad), ay - (far - 6) * Math.cos(rad) + 8);
      out.bearings.push(b);
    }
    ctx.textAlign = "left";
  }
  for (const m of s.marks || []) {
    const rp = m.range * pxPerM, b = m.bearing_deg * DEG;
    ctx.strokeStyle = TRACK_COLORS[m.kind] || "#888";
    ctx.lineWidth = m.kind === "diver" ? 2 : 1;
    ctx.beginPath();
    ctx.arc(ax + rp * Math.sin(b), ay - rp * Math.cos(b), 7, 0, 2 * Math.PI);
    ctx.stroke();
  }
  ctx.restore();
  return out;
}

// ---------- camera panel
function drawCamera() {
  const { drawn } = drawLatestImages("camera", state.camera);
  $("camera-caption").textContent = drawn.map(({ key, s }) =>
    `${key} · t=${fmt(s.t, 1)} s · ${s.img.width}×${s.img.height}`).join("  |  ");
}

// ---------- plots
// "Nice" tick values (1, 2, 5 × 10^k apart) covering [lo, hi], about `count` of them and
// at least two, with labels of just enough decimals that no two read the same.
function niceTicks(lo, hi, count) {
  let ticks = [];
  for (let want = Math.max(count, 1); ticks.length < 2 && want < 1000; want *= 2) {
    const step = niceStep((hi - lo) / want);
    const digits = Math.max(0, -Math.floor(Math.log10(step) + 1e-9));
    ticks = [];
    for (let k = Math.ceil(lo / step - 1e-9); k * step <= hi + step * 1e-9; k++) {
      const value = k * step;
      ticks.push({ value, text: value.toFixed(digits) });
    }
  }
  return ticks;
}
state.niceTicks = niceTicks; // for tests

// Polyline segments of one series: a null value (a gap) ends a segment.
function segmentsOf(arr) {
  const out = [];
  let cur = [];
  for (const p of arr) {
    if (p[1] === null) {
      if (cur.length) out.push(cur);
      cur = [];
    } else cur.push(p);
  }
  if (cur.length) out.push(cur);
  return out;
}

function drawPlots() {
  const c = $("plots");
  const dpr = sizeCanvas(c);
  const ctx = c.getContext("2d");
  ctx.setTransform(dpr, 0, 0, dpr, 0, 0);
  const w = c.clientWidth, h = c.clientHeight;
  ctx.fillStyle = "#071a2b";
  ctx.fillRect(0, 0, w, h);
  const t1 = state.frame ? state.frame.t : 0;
  const t0 = t1 - PLOT_WINDOW;
  const rows = [
    { title: "range to diver (m)", series: { range: state.plots.range }, invert: false },
    { title: "depth (m)", series: state.plots.depth, invert: true },
    { title: "speed (m/s)", series: state.plots.speed, invert: false },
  ];
  const axisH = 16; // the time axis under the last row
  const rh = (h - axisH) / rows.length;
  const x0 = 44, x1 = w - 6;
  const tx = (t) => x0 + ((t - t0) / PLOT_WINDOW) * (x1 - x0);
  const timeTicks = niceTicks(t0, t1, Math.max(2, Math.floor((x1 - x0) / 60)))
    .filter((k) => k.value >= Math.max(t0, 0) - 1e-9);
  const layout = { time: timeTicks.map((k) => ({ ...k, x: tx(k.value) })), rows: [] };
  ctx.font = "10px system-ui, sans-serif";
  rows.forEach((row, i) => {
    const y0 = i * rh + 14, y1 = (i + 1) * rh - 4;
    let vmin = Infinity, vmax = -Infinity;
    for (const arr of Object.values(row.series)) for (const p of arr) {
      if (p[1] === null || p[0] < t0) continue;
      vmin = Math.min(vmin, p[1]); vmax = Math.max(vmax, p[1]);
    }
    label(ctx, row.title, 4, i * rh + 11, "#8fb");
    if (!("range" in row.series)) {  // legend: agent names in colour
      let lx = w - 6;
      ctx.font = "10px system-ui, sans-serif";
      for (const name of Object.keys(row.series).reverse()) {
        lx -= ctx.measureText(name).width + 8;
        ctx.fillStyle = state.colors[name] || "#ccc";
        ctx.fillText(name, lx, i * rh + 11);
      }
    }
    // vertical time grid
    ctx.strokeStyle = "rgba(120,170,210,0.12)";
    ctx.beginPath();
    for (const k of layout.time) { ctx.moveTo(k.x, y0); ctx.lineTo(k.x, y1); }
    ctx.stroke();
    ctx.strokeStyle = "#24435e";
    ctx.strokeRect(x0, y0, x1 - x0, y1 - y0);
    const entry = { title: row.title, ticks: [], segments: {} };
    layout.rows.push(entry);
    if (!isFinite(vmin)) return;
    if (vmax - vmin < 1e-6) { vmin -= 0.5; vmax += 0.5; }
    const pad = (vmax - vmin) * 0.08;
    vmin -= pad; vmax += pad;
    const ty = (v) => (row.invert ? y0 + ((v - vmin) / (vmax - vmin)) * (y1 - y0)
      : y1 - ((v - vmin) / (vmax - vmin)) * (y1 - y0));
    // value ticks: nice numbers, a label each, a faint grid line
    let ticks = [];
    for (let n = Math.max(2, Math.min(5, Math.floor((y1 - y0) / 16))); n >= 1; n--) {
      ticks = niceTicks(vmin, vmax, n); // fewer ticks until their labels are 12 px apart
      if (ticks.length < 2 || Math.abs(ty(ticks[1].value) - ty(ticks[0].value)) >= 12) break;
    }
    ctx.textAlign = "right";
    for (const k of ticks) {
      const y = ty(k.value);
      entry.ticks.push({ ...k, y });
      ctx.strokeStyle = "rgba(120,170,210,0.12)";
      ctx.beginPath(); ctx.moveTo(x0, y); ctx.lineTo(x1, y); ctx.stroke();
      ctx.fillStyle = "#7f98ad";
      ctx.fillText(k.text, x0 - 3, y + 3);
    }
    ctx.textAlign = "left";
    ctx.save();
    ctx.beginPath();
    ctx.rect(x0, y0, x1 - x0, y1 - y0);
    ctx.clip();
    for (const [name, arr] of Object.entries(row.series)) {
      ctx.strokeStyle = name === "range" ? "#8fb" : state.colors[name] || "#ccc";
      ctx.lineWidth = 1.5;
      const segs = segmentsOf(arr);
      entry.segments[name] = segs.map((seg) => seg.map((p) => [tx(p[0]), ty(p[1])]));
      for (const seg of entry.segments[name]) {
        ctx.beginPath();
        seg.forEach(([x, y], j) => (j === 0 ? ctx.moveTo(x, y) : ctx.lineTo(x, y)));
        if (seg.length === 1) ctx.arc(seg[0][0], seg[0][1], 0.8, 0, 2 * Math.PI);
        ctx.stroke();
      }
    }
    ctx.restore();
  });
  // time axis: seconds of simulated time
  const ya = h - axisH + 2;
  ctx.fillStyle = "#7f98ad";
  ctx.strokeStyle = "#24435e";
  ctx.textAlign = "center";
  for (const k of layout.time) {
    ctx.beginPath(); ctx.moveTo(k.x, ya - 6); ctx.lineTo(k.x, ya - 2); ctx.stroke();
    ctx.fillText(k.text, k.x, ya + 9);
  }
  ctx.textAlign = "left";
  ctx.fillText("t (s)", 4, ya + 9);
  state.plotLayout = layout;
}

// ------------------------------------------------------------------ 3-D view
const view3d = {
  THREE: null,
  renderer: null,
  scene: null,
  camera: null,
  staticGroup: null,
  agentObjs: {},
  teamObjs: {}, // "<what>:<name>" -> mesh of a tool, load or site
  figureObjs: {}, // diver -> THREE.LineSegments of its posed figure
  orbit: { az: -0.6, el: 0.55, dist: 45 },
  target: [0, 0, 0],
  pendingScene: null,

  async init() {
    const host = $("view3d");
    const probe = document.createElement("canvas");
    let ok = false;
    try {
      ok = !!(probe.getContext("webgl2") || probe.getContext("webgl"));
    } catch (e) {
      ok = false;
    }
    if (!ok) {
      host.innerHTML = '<div class="nogl">3-D view unavailable: this browser has no WebGL.</div>';
      return;
    }
    const THREE = (this.THREE = await import("./three.module.min.js"));
    this.renderer = new THREE.WebGLRenderer({ antialias: true, preserveDrawingBuffer: true });
    this.renderer.setPixelRatio(window.devicePixelRatio || 1);
    host.appendChild(this.renderer.domElement);
    this.scene = new THREE.Scene();
    this.scene.background = new THREE.Color(0x06304a);
    this.scene.fog = new THREE.Fog(0x06304a, 60, 220);
    this.camera = new THREE.PerspectiveCamera(50, 1, 0.1, 2000);
    this.scene.add(new THREE.HemisphereLight(0xbfe3ff, 0x303020, 1.6));
    const sun = new THREE.DirectionalLight(0xffffff, 1.4);
    sun.position.set(20, 60, 10);
    this.scene.add(sun);
    state.gl = true;
    this.bindOrbit(this.renderer.domElement);
    if (this.pendingScene) this.setScene(this.pendingScene);
  },

  // NED (north, east, down) -> three.js (x = east, y = up, z = south)
  v(n, e, d) {
    return new this.THREE.Vector3(e, -d, -n);
  },

  setScene(scene) {
    if (!this.renderer) {
      this.pendingScene = scene;
      return;
    }
    const THREE = this.THREE;
    if (this.staticGroup) this.scene.remove(this.staticGroup);
    const g = (this.staticGroup = new THREE.Group());
    const mat = (color, opts = {}) => new THREE.MeshLambertMaterial({ color, ...opts });
    if (scene.seafloor && scene.seafloor.vertices && scene.seafloor.vertices.length) {
      g.add(this.meshFrom(scene.seafloor.vertices, scene.seafloor.faces,
        mat(0x8a7a55, { side: THREE.DoubleSide })));
    }
    for (const o of scene.objects || []) {
      const obj = this.objectFrom(o, mat);
      if (obj) g.add(obj);
    }
    // sea surface as a faint grid
    const b = scene.bounds || [[-50, -50, 0], [50, 50, 20]];
    const size = Math.max(b[1][0] - b[0][0], b[1][1] - b[0][1], 20);
    const grid = new THREE.GridHelper(size, 20, 0x3a7ca5, 0x1d5275);
    grid.position.copy(this.v((b[0][0] + b[1][0]) / 2, (b[0][1] + b[1][1]) / 2, 0));
    g.add(grid);
    this.scene.add(g);
    const c = [(b[0][0] + b[1][0]) / 2, (b[0][1] + b[1][1]) / 2, (b[0][2] + b[1][2]) / 2];
    this.target = c;
    this.orbit.dist = Math.min(size * 0.9, 14);
    dirty.view3d = true;
  },

  meshFrom(vertices, faces, material) {
    const THREE = this.THREE;
    const pos = new Float32Array(vertices.length * 3);
    vertices.forEach((p, i) => {
      pos[3 * i] = p[1]; pos[3 * i + 1] = -p[2]; pos[3 * i + 2] = -p[0];
    });
    const geo = new THREE.BufferGeometry();
    geo.setAttribute("position", new THREE.BufferAttribute(pos, 3));
    geo.setIndex(faces.flat());
    geo.computeVertexNormals();
    return new THREE.Mesh(geo, material);
  },

  // Primitive in its own NED-like frame (x fwd/north, y east, z down), rotated by the 3x3
  // "rotation" (object -> world NED) and placed at position_ned.
  objectFrom(o, mat) {
    const THREE = this.THREE;
    if (o.kind === "mesh") {
      if (!o.vertices || !o.faces) return null;
      const floor = /floor|seabed|bottom/i.test(o.label || "");
      const color = floor ? 0x8a7a55 : o.color ? new THREE.Color(o.color) : 0x9aa5a8;
      return this.meshFrom(o.vertices, o.faces, mat(color, { side: THREE.DoubleSide }));
    }
    const size = Array.isArray(o.size) ? o.size : null;
    let geo;
    if (o.kind === "box") {
      const s = size || [1, 1, 1];
      geo = new THREE.BoxGeometry(s[1], s[2], s[0]); // three: x=east, y=down(-), z=north(-)
    } else if (o.kind === "cylinder") {
      const r = o.radius ?? (size ? size[0] : 0.5);
      const hgt = o.height ?? (size ? size[1] : 1);
      geo = new THREE.CylinderGeometry(r, r, hgt, 24); // along local z (down) = three y
    } else if (o.kind === "sphere") {
      geo = new THREE.SphereGeometry(o.radius ?? (size ? size[0] : 0.5), 24, 16);
    } else if (o.kind === "torus") {
      const r = o.radius ?? (size ? size[0] : 1);
      const tube = o.tube ?? (size ? size[1] : 0.1);
      geo = new THREE.TorusGeometry(r, tube, 12, 40);
      geo.rotateX(Math.PI / 2); // axis along local z (down)
    } else {
      return null;
    }
    const mesh = new THREE.Mesh(geo, mat(o.color ? new THREE.Color(o.color) : 0x9aa5a8));
    if (o.rotation) {
      // M_three = P R P^T with P: (n, e, d) -> (e, -d, -n)
      const R = o.rotation;
      const P = [[0, 1, 0], [0, 0, -1], [-1, 0, 0]];
      const M = [[0, 0, 0], [0, 0, 0], [0, 0, 0]];
      for (let i = 0; i < 3; i++) for (let j = 0; j < 3; j++) {
        let s = 0;
        for (let k = 0; k < 3; k++) for (let l = 0; l < 3; l++) s += P[i][k] * R[k][l] * P[j][l];
        M[i][j] = s;
      }
      const m4 = new THREE.Matrix4().set(
        M[0][0], M[0][1], M[0][2], 0, M[1][0], M[1][1], M[1][2], 0, M[2][0], M[2][1], M[2][2], 0, 0, 0, 0, 1);
      mesh.quaternion.setFromRotationMatrix(m4);
    }
    const p = o.position_ned || [0, 0, 0];
    mesh.position.copy(this.v(p[0], p[1], p[2]));
    return mesh;
  },

  agentObject(a) {
    const THREE = this.THREE;
    const g = new THREE.Group();
    const color = new THREE.Color(state.colors[a.name] || "#ffffff");
    const m = new THREE.MeshLambertMaterial({ color });
    if (a.kind === "rov") {
      const body = new THREE.Mesh(new THREE.BoxGeometry(0.29, 0.22, 0.37), m);
      g.add(body);
    } else if (a.kind === "diver") {
      const torso = new THREE.Mesh(new THREE.CylinderGeometry(0.18, 0.14, 1.5, 12), m);
      torso.rotation.x = Math.PI / 2; // lie horizontally, head forward (-z)
      g.add(torso);
      const head = new THREE.Mesh(new THREE.SphereGeometry(0.14, 12, 8), m);
      head.position.set(0, 0, -0.85);
      g.add(head);
      const tank = new THREE.Mesh(new THREE.CylinderGeometry(0.09, 0.09, 0.6, 10),
        new THREE.MeshLambertMaterial({ color: 0x888888 }));
      tank.rotation.x = Math.PI / 2;
      tank.position.set(0, 0.2, -0.2);
      g.add(tank);
    } else {
      const hull = new THREE.Mesh(new THREE.ConeGeometry(0.4, 3, 12), m);
      hull.rotation.x = -Math.PI / 2;
      g.add(hull);
    }
    this.scene.add(g);
    return { group: g, body: [...g.children], wedges: [], wedgeKey: "" };
  },

  // Tools and loads as small boxes, a flange's cover coloured from red (all bolts in)
  // to green (all out), a hatch's lid at its angle, a lift bag as a sphere of its gas
  // volume, each diver's posed figure as white line segments.
  updateTeam(team) {
    const THREE = this.THREE;
    const seen = new Set();
    const place = (key, make, n, e, d) => {
      let m = this.teamObjs[key];
      if (!m) {
        m = this.teamObjs[key] = make();
        this.scene.add(m);
      }
      m.position.copy(this.v(n, e, d));
      seen.add(key);
      return m;
    };
    const mat = (kind) => new THREE.MeshLambertMaterial({ color: new THREE.Color(teamColor(kind)) });
    for (const o of (team && team.objects) || []) {
      if (o.kind === "lift_bag") continue; // drawn as its site, by its gas volume
      place(`o:${o.name}`, () => new THREE.Mesh(new THREE.BoxGeometry(0.25, 0.12, 0.25),
        mat(o.kind)), o.north, o.east, o.depth);
    }
    for (const site of (team && team.sites) || []) {
      if (site.kind === "lift_bag") {
        const m = place(`s:${site.name}`, () => new THREE.Mesh(new THREE.SphereGeometry(1, 16, 12),
          mat("lift_bag")), site.north, site.east, site.depth);
        const litres = Math.max(site.litres, 0.5); // an empty bag: a folded bundle
        m.scale.setScalar(Math.cbrt((3 * litres * 1e-3) / (4 * Math.PI)));
      } else if (site.kind === "flange") {
        const m = place(`s:${site.name}`, () => new THREE.Mesh(
          new THREE.CylinderGeometry(0.115, 0.115, 0.05, 24), mat("flange")),
          site.north, site.east, site.depth);
        const k = site.bolts ? site.bolts_out / site.bolts : 0;
        m.material.color.setRGB(0.9 * (1 - k) + 0.2 * k, 0.25 * (1 - k) + 0.8 * k, 0.2);
        m.visible = site.cover_on;
      } else if (site.kind === "hatch") {
        const m = place(`s:${site.name}`, () => new THREE.Mesh(new THREE.BoxGeometry(0.6, 0.02, 0.6),
          mat("hatch")), site.north, site.east, site.depth);
        m.rotation.x = -site.angle_deg * DEG;
      }
    }
    for (const [key, m] of Object.entries(this.teamObjs)) {
      if (!seen.has(key)) {
        this.scene.remove(m);
        delete this.teamObjs[key];
      }
    }
    const figures = (team && team.figures) || {};
    for (const [name, fig] of Object.entries(figures)) {
      let lines = this.figureObjs[name];
      const n = fig.bones.length * 2;
      if (!lines || lines.geometry.attributes.position.count !== n) {
        if (lines) this.scene.remove(lines);
        const geo = new THREE.BufferGeometry();
        geo.setAttribute("position", new THREE.BufferAttribute(new Float32Array(3 * n), 3));
        lines = this.figureObjs[name] = new THREE.LineSegments(geo,
          new THREE.LineBasicMaterial({ color: 0xffffff }));
        this.scene.add(lines);
      }
      const pos = lines.geometry.attributes.position;
      fig.bones.forEach(([i, j], k) => {
        for (const [slot, p] of [[2 * k, fig.points[i]], [2 * k + 1, fig.points[j]]]) {
          pos.setXYZ(slot, p[1], -p[2], -p[0]);
        }
      });
      pos.needsUpdate = true;
      lines.geometry.computeBoundingSphere();
    }
    for (const [name, lines] of Object.entries(this.figureObjs)) {
      if (!(name in figures)) {
        this.scene.remove(lines);
        delete this.figureObjs[name];
      }
    }
    // a diver drawn as its figure hides its primitive body (the sonar wedge stays)
    for (const [name, obj] of Object.entries(this.agentObjs)) {
      for (const m of obj.body) m.visible = !(name in figures);
    }
  },

  // Translucent horizontal fan: apex at the vehicle, ±fov/2 about forward, radius max_range.
  wedge(fovDeg, maxRange) {
    const THREE = this.THREE;
    const half = (fovDeg * DEG) / 2;
    const geo = new THREE.CircleGeometry(maxRange, 48, Math.PI / 2 - half, 2 * half);
    geo.rotateX(-Math.PI / 2); // circle plane (x,y) -> horizontal (x,z); +y (forward) -> -z
    const mat = new THREE.MeshBasicMaterial({ color: 0x6ff0ff, transparent: true, opacity: 0.18,
      side: THREE.DoubleSide, depthWrite: false });
    return new THREE.Mesh(geo, mat);
  },

  update() {
    if (!this.renderer) return;
    const host = $("view3d");
    const w = Math.max(1, host.clientWidth), h = Math.max(1, host.clientHeight);
    const size = this.renderer.getSize(new this.THREE.Vector2());
    if (size.x !== w || size.y !== h) {
      this.renderer.setSize(w, h, false);
      this.camera.aspect = w / h;
      this.camera.updateProjectionMatrix();
    }
    for (const a of Object.values(state.agents)) {
      const obj = this.agentObjs[a.name] || (this.agentObjs[a.name] = this.agentObject(a));
      obj.group.position.copy(this.v(a.north, a.east, a.depth));
      obj.group.rotation.y = -a.heading_deg * DEG;
      // one wedge per sonar of the agent, as wide and long as its fan
      const fans = Object.values(state.sonar).filter((s) => s.agent === a.name);
      const key = fans.map((s) => `${s.fov_deg}/${s.max_range}`).sort().join(",");
      if (fans.length && obj.wedgeKey !== key) {
        for (const w of obj.wedges) obj.group.remove(w);
        obj.wedges = fans.map((s) => this.wedge(s.fov_deg, s.max_range));
        for (const w of obj.wedges) obj.group.add(w);
        obj.wedgeKey = key;
      }
    }
    this.updateTeam(state.team);
    const sel = state.agents[state.selected];
    const t = sel ? [sel.north, sel.east, sel.depth] : this.target;
    const o = this.orbit;
    const target = this.v(t[0], t[1], t[2]);
    this.camera.position.set(
      target.x + o.dist * Math.cos(o.el) * Math.sin(o.az),
      target.y + o.dist * Math.sin(o.el),
      target.z + o.dist * Math.cos(o.el) * Math.cos(o.az));
    this.camera.lookAt(target);
    this.renderer.render(this.scene, this.camera);
  },

  bindOrbit(el) {
    let d = null;
    el.addEventListener("mousedown", (ev) => { d = { x: ev.clientX, y: ev.clientY }; });
    window.addEventListener("mouseup", () => { d = null; });
    window.addEventListener("mousemove", (ev) => {
      if (!d) return;
      this.orbit.az -= (ev.clientX - d.x) * 0.01;
      this.orbit.el = Math.min(Math.max(this.orbit.el + (ev.clientY - d.y) * 0.01, -1.4), 1.5);
      d = { x: ev.clientX, y: ev.clientY };
      dirty.view3d = true;
    });
    el.addEventListener("wheel", (ev) => {
      ev.preventDefault();
      this.orbit.dist = Math.min(Math.max(this.orbit.dist * Math.exp(ev.deltaY * 0.0015), 1), 1500);
      dirty.view3d = true;
    }, { passive: false });
  },
};

// ------------------------------------------------------------------ render loop
let lastDraw = 0;
state.drawCount = 0;
function loop(now) {
  if (dirty.map) { dirty.map = false; drawMap(); state.drawCount += 1; }
  if (dirty.sonar) { dirty.sonar = false; drawSonar(); }
  if (dirty.camera) { dirty.camera = false; drawCamera(); }
  if (dirty.plots && now - lastDraw > 90) { dirty.plots = false; lastDraw = now; drawPlots(); }
  if (dirty.view3d) { dirty.view3d = false; view3d.update(); }
  requestAnimationFrame(loop);
}
new ResizeObserver(() => {
  dirty.map = dirty.sonar = dirty.camera = dirty.plots = dirty.view3d = true;
})
  .observe(document.body);

state.view3d = view3d; // for tests
view3d.init().catch((e) => {
  state.errors.push(String(e));
  $("view3d").innerHTML = '<div class="nogl">3-D view failed to start.</div>';
});
connect();
requestAnimationFrame(loop);
