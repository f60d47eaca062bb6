// Cyborg dashboard: plain JavaScript, no build step, nothing loaded from outside the robot.
// Reads the robot's API: /api/ws (live records), /api/status, /api/health, /api/machine,
// /api/graph.svg, /api/emotions, /api/map, /api/route and /api/records; sends commands with POST.
"use strict";

(() => {
  const $ = (id) => document.getElementById(id);

  const PLOT_WINDOW = 300; // seconds of robot time in the PAD plot
  const LOG_KEEP = 5000; // records kept for the log
  const LOG_SHOWN = 400; // rows drawn at once
  const TRAIL = 60; // poses kept for the robot's trail
  const EMOTION_COLOURS = {
    neutral: "#a0a7b4",
    happy: "#f5c518",
    loved: "#ff6fae",
    curious: "#3ec7e0",
    dignified: "#a78bfa",
    surprised: "#ff9f43",
    angry: "#e5484d",
    sad: "#5b7bd5",
    bored: "#7d8597",
    unconcerned: "#6cc5b0",
  };
  const SERIES = [
    ["p", "pleasure", "#4cc38a"],
    ["a", "arousal", "#f0a04b"],
    ["d", "dominance", "#6ea8fe"],
  ];

  const dash = {
    lastSeq: 0,
    syncing: true,
    pending: [],
    retry: 500,
    status: {},
    parents: {},
    prototypes: {},
    emotion: null,
    history: [],
    records: [],
    t: 0,
    health: null,
    hasBase: null,
    map: null,
    mapImage: null,
    route: null,
    remaining: null,
    pathState: null,
    pose: null,
    trail: [],
    drawQueued: false,
  };
  window.cyborgDashboard = dash; // for the tests and for poking around in the console

  // --- helpers ---------------------------------------------------------------------------

  async function getJSON(url) {
    const response = await fetch(url, { cache: "no-store" });
    if (!response.ok) throw new Error(`${url}: HTTP ${response.status} ${await response.text()}`);
    return response.json();
  }

  async function post(url, body) {
    const response = await fetch(url, {
      method: "POST",
      headers: { "Content-Type": "application/json" },
      body: JSON.stringify(body),
    });
    const data = await response.json().catch(() => ({}));
    if (!response.ok) throw new Error(data.error || `${url}: HTTP ${response.status}`);
    return data;
  }

  function say(text, isError = false) {
    const box = $("control-message");
    box.textContent = text;
    box.classList.toggle("error", isError);
  }

  function fmtClock(seconds) {
    if (seconds == null || !isFinite(seconds)) return "–";
    const s = Math.max(0, Math.floor(seconds));
    const h = Math.floor(s / 3600);
    const m = Math.floor((s % 3600) / 60);
    const two = (n) => String(n).padStart(2, "0");
    return h ? `${h}:${two(m)}:${two(s % 60)}` : `${m}:${two(s % 60)}`;
  }

  function fmtAgo(seconds) {
    if (seconds == null) return "never";
    if (seconds < 1) return "now";
    if (seconds < 90) return `${seconds.toFixed(0)} s ago`;
    if (seconds < 5400) return `${(seconds / 60).toFixed(0)} min ago`;
    return `${(seconds / 3600).toFixed(1)} h ago`;
  }

  const signed = (v) => (v >= 0 ? "+" : "") + Number(v).toFixed(2);

  function emotionColour(name, p = 0, a = 0) {
    if (EMOTION_COLOURS[name]) return EMOTION_COLOURS[name];
    const hue = ((Math.atan2(a, p) * 180) / Math.PI + 360) % 360; // unknown names: a hue from P and A
    return `hsl(${hue.toFixed(0)}, 65%, 60%)`;
  }

  function el(tag, className, text) {
    const node = document.createElement(tag);
    if (className) node.className = className;
    if (text != null) node.textContent = text;
    return node;
  }

  function fitCanvas(canvas) {
    const ratio = window.devicePixelRatio || 1;
    const width = Math.max(1, Math.round(canvas.clientWidth * ratio));
    const height = Math.max(1, Math.round(canvas.clientHeight * ratio));
    if (canvas.width !== width || canvas.height !== height) {
      canvas.width = width;
      canvas.height = height;
    }
    const ctx = canvas.getContext("2d");
    ctx.setTransform(ratio, 0, 0, ratio, 0, 0);
    return { ctx, w: canvas.clientWidth, h: canvas.clientHeight };
  }

  function scheduleDraw() {
    if (dash.drawQueued) return;
    dash.drawQueued = true;
    requestAnimationFrame(() => {
      dash.drawQueued = false;
      drawPlot();
      drawSpace();
      drawMap();
    });
  }

  // --- status and the state machine ------------------------------------------------------

  function applyStatus(status) {
    dash.status = { ...dash.status, ...status };
    const s = dash.status;
    $("top-state").textContent = s.state || "–";
    $("events-state").textContent = s.state || "–";
    renderEventButtons(s.valid_events || []);
    highlightGraph();
    if (s.emotion != null) {
      applyEmotion({ emotion: s.emotion, pleasure: s.pleasure, arousal: s.arousal, dominance: s.dominance });
    }
  }

  async function refreshStatus() {
    try {
      const status = await getJSON("/api/status");
      applyStatus({ valid_events: status.valid_events, state: status.state,
        previous_state: status.previous_state, event: status.event });
    } catch (error) {
      say(`could not read the status: ${error.message}`, true);
    }
  }

  async function loadGraph() {
    const box = $("graph");
    try {
      const [machine, response] = await Promise.all([getJSON("/api/machine"), fetch("/api/graph.svg")]);
      if (!response.ok) throw new Error(`/api/graph.svg: HTTP ${response.status} ${await response.text()}`);
      for (const state of machine.states) dash.parents[state.name] = state.parent;
      const text = await response.text();
      box.innerHTML = text.slice(text.indexOf("<svg"));
      const svg = box.querySelector("svg");
      svg.removeAttribute("width");
      svg.removeAttribute("height");
      svg.setAttribute("preserveAspectRatio", "xMidYMid meet");
      const leaves = machine.states.filter((s) => s.leaf).length;
      $("graph-caption").textContent = `${leaves} states · initial ${machine.initial}`;
      highlightGraph();
    } catch (error) {
      box.innerHTML = "";
      box.append(el("p", "muted", `The state machine cannot be drawn: ${error.message}`));
    }
  }

  function highlightGraph() {
    const box = $("graph");
    const s = dash.status;
    box.querySelectorAll(".active, .active-parent, .last, .valid").forEach((node) => {
      node.classList.remove("active", "active-parent", "last", "valid");
    });
    if (!s.state) return;
    const node = document.getElementById(`state:${s.state}`);
    if (node) node.classList.add("active");
    for (let parent = dash.parents[s.state]; parent; parent = dash.parents[parent]) {
      const cluster = document.getElementById(`super:${parent}`);
      if (cluster) cluster.classList.add("active-parent");
    }
    // The transitions the active state (or a superstate around it) can take now.
    for (let from = s.state; from; from = dash.parents[from]) {
      box.querySelectorAll(`g.edge[id^="edge:${CSS.escape(from)}:"]`).forEach((edge) => edge.classList.add("valid"));
    }
    // The transition may belong to the state left or to a superstate around it.
    for (let from = s.previous_state; from && s.event; from = dash.parents[from]) {
      const edge = document.getElementById(`edge:${from}:${s.event}`);
      if (edge) {
        edge.classList.add("last");
        break;
      }
    }
  }

  function renderEventButtons(events) {
    const box = $("event-buttons");
    const key = events.join(",");
    if (box.dataset.key === key) return;
    box.dataset.key = key;
    box.replaceChildren();
    const outcomes = new Set(["succeeded", "aborted"]);
    const sorted = [...events].sort((x, y) => outcomes.has(x) - outcomes.has(y) || x.localeCompare(y));
    for (const name of sorted) {
      const button = el("button", outcomes.has(name) ? "outcome" : "", name);
      button.type = "button";
      button.dataset.event = name;
      button.title = `send the event ${name}`;
      button.addEventListener("click", () => sendEvent(name));
      box.append(button);
    }
    if (!events.length) box.append(el("span", "muted small", "none"));
  }

  async function sendEvent(name) {
    try {
      const reply = await post("/api/event", { name });
      say(reply.is_transition === false ? `sent ${name} (no transition of ${dash.status.state} any more)` : `sent ${name}`);
    } catch (error) {
      say(`event not sent: ${error.message}`, true);
    }
  }

  // --- health ------------------------------------------------------------------------------

  async function refreshHealth() {
    let health;
    try {
      health = await getJSON("/api/health");
    } catch (error) {
      $("health-caption").textContent = "no answer";
      return;
    }
    dash.health = health;
    dash.t = Math.max(dash.t, health.t);
    $("top-time").textContent = fmtClock(dash.t);
    $("top-phase").textContent = health.phase;
    const sw = $("emotion-switch");
    if (document.activeElement !== sw) sw.checked = health.emotion_enabled;
    $("emotion-switch-state").textContent = health.emotion_enabled ? "" : "switched off";
    $("health-caption").textContent =
      `${health.active_state || "–"} for ${health.seconds_in_state.toFixed(0)} s · goal ${health.goal_status || "none"}`;

    const stats = $("health-stats");
    stats.replaceChildren();
    const labels = {
      events_received: "events", events_invalid: "invalid", events_overflow: "overflow",
      handovers: "handovers", preempt_timeouts: "preempt timeouts",
      connect_failures: "connect failures", succeeded_fallbacks: "fallbacks",
    };
    const bad = new Set(["events_overflow", "preempt_timeouts", "connect_failures"]);
    for (const [key, value] of Object.entries(health.stats)) {
      const chip = el("span", `stat${bad.has(key) && value ? " bad" : ""}`, `${labels[key] || key} `);
      chip.append(el("b", "", String(value)));
      stats.append(chip);
    }

    const body = $("health-table").querySelector("tbody");
    body.replaceChildren();
    const modules = [...health.modules].sort((x, y) => (y.active - x.active) || (x.states.length ? 0 : 1) - (y.states.length ? 0 : 1));
    for (const m of modules) {
      const row = el("tr", m.active ? "active" : "");
      row.dataset.module = m.name;
      row.append(el("td", "", m.name));
      const states = el("td", "muted", m.states.join(", ") || "–");
      states.title = m.states.join(", ");
      row.append(states);
      const goal = el("td");
      if (m.goal_status) goal.append(el("span", `goal goal-${m.goal_status}`, m.goal_status.toLowerCase()));
      else goal.append(el("span", "muted", m.states.length ? "idle" : "–"));
      row.append(goal);
      const since = m.active ? `for ${health.seconds_in_state.toFixed(0)} s` : (m.states.length ? fmtAgo(m.seconds_since_active) : "");
      row.append(el("td", "", since));
      body.append(row);
    }

    if (health.has_base !== dash.hasBase) {
      dash.hasBase = health.has_base;
      if (health.has_base) loadMap();
      else showNoBase();
    }
    scheduleDraw();
  }

  // --- emotion -------------------------------------------------------------------------------

  function applyEmotion(r) {
    const current = { name: r.emotion, p: Number(r.pleasure), a: Number(r.arousal), d: Number(r.dominance) };
    dash.emotion = current;
    const colour = emotionColour(current.name, current.p, current.a);
    $("top-emotion").textContent = current.name;
    $("top-emotion").style.color = colour;
    const name = $("emotion-name");
    name.textContent = current.name;
    name.style.borderLeftColor = colour;
    name.style.color = colour;
    for (const [key] of SERIES) {
      const v = Math.max(-1, Math.min(1, current[key]));
      $(`val-${key}`).textContent = signed(v);
      const bar = $(`bar-${key}`);
      bar.style.left = `${50 + Math.min(0, v) * 50}%`;
      bar.style.width = `${Math.abs(v) * 50}%`;
    }
    scheduleDraw();
  }

  function drawPlot() {
    const { ctx, w, h } = fitCanvas($("pad-plot"));
    const pad = { l: 28, r: 8, t: 20, b: 16 };
    const history = dash.history;
    const now = Math.max(dash.t, history.length ? history[history.length - 1].t : 0);
    // The window grows with the data, from one minute up to PLOT_WINDOW.
    const span = history.length ? now - history[0].t : 0;
    const window_ = Math.min(PLOT_WINDOW, Math.max(60, Math.ceil(span / 60) * 60));
    $("plot-window").textContent = `${window_ / 60} min`;
    const start = now - window_;
    const x = (t) => pad.l + ((t - start) / window_) * (w - pad.l - pad.r);
    const y = (v) => pad.t + ((1 - v) / 2) * (h - pad.t - pad.b);
    ctx.clearRect(0, 0, w, h);
    ctx.font = "10px system-ui, sans-serif";
    ctx.lineWidth = 1;
    for (const v of [-1, -0.5, 0, 0.5, 1]) {
      ctx.strokeStyle = v === 0 ? "#4a5160" : "#2e3440";
      ctx.beginPath();
      ctx.moveTo(pad.l, y(v));
      ctx.lineTo(w - pad.r, y(v));
      ctx.stroke();
      ctx.fillStyle = "#8a93a3";
      ctx.textAlign = "right";
      ctx.textBaseline = "middle";
      ctx.fillText(v.toString(), pad.l - 4, y(v));
    }
    ctx.textAlign = "center";
    ctx.textBaseline = "top";
    const step = window_ <= 60 ? 15 : 60;
    for (let ago = 0; ago <= window_; ago += step) {
      const label = ago === 0 ? "now" : step < 60 ? `-${ago}s` : `-${ago / 60}m`;
      ctx.fillText(label, Math.min(Math.max(x(now - ago), pad.l + 12), w - pad.r - 12), h - pad.b + 3);
    }
    ctx.textAlign = "left";
    ctx.textBaseline = "middle";
    let lx = pad.l + 6;
    for (const [, label, colour] of SERIES) {
      ctx.fillStyle = colour;
      ctx.fillRect(lx, 8, 10, 3);
      ctx.fillStyle = "#aeb5c2";
      ctx.fillText(label, lx + 13, 10);
      lx += 20 + ctx.measureText(label).width;
    }
    const points = history;
    if (!points.length) return;
    let first = 0;
    while (first < points.length - 1 && points[first + 1].t <= start) first++;
    ctx.lineWidth = 1.8;
    for (const [key, , colour] of SERIES) {
      ctx.strokeStyle = colour;
      ctx.beginPath();
      ctx.moveTo(x(Math.max(points[first].t, start)), y(points[first][key]));
      for (let i = first + 1; i < points.length; i++) {
        ctx.lineTo(x(points[i].t), y(points[i - 1][key]));
        ctx.lineTo(x(points[i].t), y(points[i][key]));
      }
      ctx.lineTo(x(now), y(points[points.length - 1][key]));
      ctx.stroke();
    }
  }

  function drawSpace() {
    const { ctx, w, h } = fitCanvas($("pad-space"));
    const size = Math.min(w, h) - 24;
    const cx = w / 2;
    const cy = h / 2;
    const x = (p) => cx + (p * size) / 2;
    const y = (a) => cy - (a * size) / 2;
    const radius = (d) => 3 + (d + 1) * 3.5;
    ctx.clearRect(0, 0, w, h);
    ctx.strokeStyle = "#2e3440";
    ctx.lineWidth = 1;
    ctx.strokeRect(x(-1), y(1), size, size);
    ctx.strokeStyle = "#4a5160";
    ctx.beginPath();
    ctx.moveTo(x(-1), cy);
    ctx.lineTo(x(1), cy);
    ctx.moveTo(cx, y(-1));
    ctx.lineTo(cx, y(1));
    ctx.stroke();
    ctx.font = "9px system-ui, sans-serif";
    ctx.fillStyle = "#8a93a3";
    ctx.textAlign = "right";
    ctx.textBaseline = "bottom";
    ctx.fillText("P", x(1) - 2, cy - 2);
    ctx.textAlign = "left";
    ctx.textBaseline = "top";
    ctx.fillText("A", cx + 3, y(1) + 2);
    ctx.font = "10px system-ui, sans-serif";
    ctx.textAlign = "center";
    const prototypes = { neutral: [0, 0, 0], ...dash.prototypes };
    const placed = []; // label boxes drawn so far (and the current point), to keep labels clear
    if (dash.emotion) {
      const r = radius(dash.emotion.d) + 3;
      placed.push({ x: x(dash.emotion.p) - r, y: y(dash.emotion.a) - r, w: 2 * r, h: 2 * r });
    }
    const overlaps = (box) => placed.some((b) => box.x < b.x + b.w && b.x < box.x + box.w && box.y < b.y + b.h && b.y < box.y + box.h);
    ctx.textBaseline = "middle";
    for (const [name, [p, a, d]] of Object.entries(prototypes)) {
      const colour = emotionColour(name, p, a);
      const current = name === dash.emotion?.name;
      ctx.globalAlpha = current ? 1 : 0.6;
      ctx.fillStyle = colour;
      ctx.beginPath();
      ctx.arc(x(p), y(a), radius(d), 0, 2 * Math.PI);
      ctx.fill();
      const tw = ctx.measureText(name).width;
      const r = radius(d) + 7;
      const spots = [[0, -r], [0, r], [r + tw / 2 - 4, 0], [-r - tw / 2 + 4, 0]];
      const boxes = spots.map(([dx, dy]) => ({ x: x(p) + dx - tw / 2, y: y(a) + dy - 6, w: tw, h: 12 }));
      const box = boxes.find((b) => !overlaps(b)) || boxes[0];
      placed.push(box);
      ctx.globalAlpha = 1;
      ctx.fillStyle = current ? "#ffffff" : "#aeb5c2";
      ctx.fillText(name, box.x + tw / 2, box.y + 6);
    }
    ctx.globalAlpha = 1;
    const recent = dash.history.slice(-40);
    if (recent.length > 1) {
      ctx.strokeStyle = "rgba(255,255,255,0.35)";
      ctx.lineWidth = 1;
      ctx.beginPath();
      recent.forEach((q, i) => (i ? ctx.lineTo(x(q.p), y(q.a)) : ctx.moveTo(x(q.p), y(q.a))));
      ctx.stroke();
    }
    const e = dash.emotion;
    if (e) {
      ctx.fillStyle = emotionColour(e.name, e.p, e.a);
      ctx.strokeStyle = "#ffffff";
      ctx.lineWidth = 2;
      ctx.beginPath();
      ctx.arc(x(e.p), y(e.a), radius(e.d) + 2, 0, 2 * Math.PI);
      ctx.fill();
      ctx.stroke();
    }
  }

  async function loadEmotions() {
    try {
      const data = await getJSON("/api/emotions");
      dash.prototypes = data.prototypes || {};
    } catch (error) {
      say(`could not read the emotion prototypes: ${error.message}`, true);
    }
    const select = $("emotion-select");
    select.replaceChildren();
    for (const name of ["neutral", ...Object.keys(dash.prototypes).sort()]) {
      const option = el("option", "", name);
      option.value = name;
      select.append(option);
    }
    scheduleDraw();
  }

  // --- map -------------------------------------------------------------------------------------

  function showNoBase() {
    dash.map = null;
    const message = $("map-message");
    message.hidden = false;
    message.firstElementChild.replaceChildren(
      "This robot has no simulated base, so there is no map to show. To add one, put ",
      el("code", "", "rosarnl_node: {kind: simulated_base}"),
      " under modules: in the robot's YAML; it drives on the packaged campus map, or on one given with ",
      el("code", "", "cyborg sim --map FILE"),
      "."
    );
    $("map-caption").textContent = "no simulated base";
    $("map-pose").textContent = "pose: – (no simulated base)";
    scheduleDraw();
  }

  async function loadMap() {
    try {
      const info = await getJSON("/api/map");
      dash.map = info;
      await loadMapImage();
      $("map-message").hidden = true;
      $("map-caption").textContent =
        `${info.source || "map"} · ${info.size_m[0].toFixed(0)} × ${info.size_m[1].toFixed(0)} m · ${info.locations.length} places`;
    } catch (error) {
      $("map-message").hidden = false;
      $("map-message").firstElementChild.textContent = `The map cannot be shown: ${error.message}`;
    }
  }

  // The grid image, shrunk by the robot to about the canvas's size in device pixels (walls kept).
  async function loadMapImage() {
    const canvas = $("map");
    const wanted = Math.ceil(Math.max(canvas.clientWidth, canvas.clientHeight, 100) * (window.devicePixelRatio || 1));
    if (dash.mapImage && dash.mapImage.wanted >= wanted) return;
    const response = await fetch(`${dash.map.image}?max=${wanted}`, { cache: "no-store" });
    if (!response.ok) throw new Error(`${dash.map.image}: HTTP ${response.status} ${await response.text()}`);
    const perPixel = Number(response.headers.get("X-Cells-Per-Pixel") || "1");
    const bitmap = await createImageBitmap(await response.blob());
    dash.mapImage = { bitmap, perPixel, wanted };
    scheduleDraw();
  }

  async function refreshRoute() {
    if (dash.map) {
      try {
        const data = await getJSON("/api/route");
        dash.route = data.route;
        dash.remaining = data.remaining;
        dash.pathState = data.path_state;
        if (data.pose) applyPose(data.pose);
        updatePoseText();
        scheduleDraw();
      } catch (error) {
        // The base may be restarting; the next poll tries again.
      }
    }
    setTimeout(refreshRoute, dash.route ? 400 : 1000); // closer look while the robot drives
  }

  function applyPose(pose) {
    if (dash.pose && pose.t < dash.pose.t) return;
    dash.pose = pose;
    const last = dash.trail[dash.trail.length - 1];
    if (!last || last.x !== pose.x || last.y !== pose.y) dash.trail.push(pose);
    if (dash.trail.length > TRAIL) dash.trail.shift();
    updatePoseText();
    scheduleDraw();
  }

  function updatePoseText() {
    const p = dash.pose;
    if (!p) return;
    let text = `pose: x ${p.x.toFixed(2)} m, y ${p.y.toFixed(2)} m, heading ${((p.theta * 180) / Math.PI).toFixed(0)}°`;
    const route = dash.remaining;
    if (route && route.length) {
      let left = 0;
      let from = [p.x, p.y];
      for (const point of route) {
        left += Math.hypot(point[0] - from[0], point[1] - from[1]);
        from = point;
      }
      text += ` · ${left.toFixed(1)} m to go`;
    } else {
      text += " · no route";
    }
    if (dash.pathState) text += ` · ${dash.pathState}`;
    $("map-pose").textContent = text;
  }

  function drawMap() {
    const canvas = $("map");
    const { ctx, w, h } = fitCanvas(canvas);
    ctx.clearRect(0, 0, w, h);
    const m = dash.map;
    if (!m) return;
    const [width, height] = m.size_m;
    const [x0, y0] = m.origin;
    const margin = 10;
    const scale = Math.min((w - 2 * margin) / width, (h - 2 * margin) / height);
    const ox = (w - width * scale) / 2;
    const oy = (h - height * scale) / 2;
    const px = (x) => ox + (x - x0) * scale;
    const py = (y) => oy + (y0 + height - y) * scale;
    if (dash.mapImage) {
      // Each image pixel covers perPixel x perPixel cells; the image's lower-left corner is the origin.
      const { bitmap, perPixel } = dash.mapImage;
      const cell = m.resolution * perPixel * scale;
      ctx.imageSmoothingEnabled = false;
      ctx.drawImage(bitmap, ox, py(y0 + bitmap.height * m.resolution * perPixel), bitmap.width * cell, bitmap.height * cell);
    }
    for (const zone of m.keep_out) {
      ctx.beginPath();
      zone.corners.forEach(([x, y], i) => (i ? ctx.lineTo(px(x), py(y)) : ctx.moveTo(px(x), py(y))));
      if (!zone.line) {
        ctx.closePath();
        ctx.fillStyle = "rgba(255, 107, 107, 0.22)";
        ctx.fill();
      }
      ctx.strokeStyle = "rgba(255, 107, 107, 0.9)";
      ctx.lineWidth = zone.line ? 2 : 1;
      ctx.stroke();
    }
    ctx.font = "10px system-ui, sans-serif";
    ctx.textAlign = "left";
    ctx.textBaseline = "middle";
    const placed = []; // label boxes so far: a label goes where it covers no other
    const overlaps = (b) => placed.some((o) => b.x < o.x + o.w && o.x < b.x + b.w && b.y < o.y + o.h && o.y < b.y + b.h);
    for (const place of m.locations) {
      const x = px(place.x);
      const y = py(place.y);
      ctx.fillStyle = "#a78bfa";
      ctx.beginPath();
      ctx.moveTo(x, y - 4);
      ctx.lineTo(x + 4, y);
      ctx.lineTo(x, y + 4);
      ctx.lineTo(x - 4, y);
      ctx.closePath();
      ctx.fill();
      placed.push({ x: x - 4, y: y - 4, w: 8, h: 8 });
    }
    for (const place of m.locations) {
      const x = px(place.x);
      const y = py(place.y);
      const tw = ctx.measureText(place.name).width + 4;
      const spots = [[x + 6, y - 6], [x - 6 - tw, y - 6], [x - tw / 2, y - 19], [x - tw / 2, y + 7]];
      const boxes = spots.map(([bx, by]) => ({ x: bx, y: by, w: tw, h: 12 }));
      const box = boxes.find((b) => !overlaps(b)) || boxes[0];
      placed.push(box);
      ctx.fillStyle = "rgba(18, 21, 26, 0.72)";
      ctx.fillRect(box.x, box.y, box.w, box.h);
      ctx.fillStyle = "#d8ccff";
      ctx.fillText(place.name, box.x + 2, box.y + 6);
    }
    if (dash.trail.length > 1) {
      ctx.strokeStyle = "rgba(110, 168, 254, 0.45)";
      ctx.lineWidth = 2;
      ctx.beginPath();
      dash.trail.forEach((q, i) => (i ? ctx.lineTo(px(q.x), py(q.y)) : ctx.moveTo(px(q.x), py(q.y))));
      ctx.stroke();
    }
    const pose = dash.pose;
    const route = dash.route;
    const line = (points) => {
      ctx.beginPath();
      points.forEach(([x, y], i) => (i ? ctx.lineTo(px(x), py(y)) : ctx.moveTo(px(x), py(y))));
      ctx.stroke();
    };
    if (route && route.length) {
      ctx.strokeStyle = "rgba(76, 195, 138, 0.35)"; // the whole planned route
      ctx.lineWidth = 2;
      line(route);
      ctx.strokeStyle = "#4cc38a"; // what is still ahead
      ctx.setLineDash([6, 4]);
      line(dash.remaining && dash.remaining.length ? dash.remaining : route);
      ctx.setLineDash([]);
      const [gx, gy] = route[route.length - 1];
      ctx.fillStyle = "#4cc38a";
      ctx.beginPath();
      ctx.arc(px(gx), py(gy), 5, 0, 2 * Math.PI);
      ctx.fill();
    }
    if (pose) {
      const x = px(pose.x);
      const y = py(pose.y);
      const r = Math.max(6, 0.35 * scale);
      ctx.fillStyle = "#6ea8fe";
      ctx.strokeStyle = "#ffffff";
      ctx.lineWidth = 2;
      ctx.beginPath();
      ctx.arc(x, y, r, 0, 2 * Math.PI);
      ctx.fill();
      ctx.stroke();
      ctx.beginPath();
      ctx.moveTo(x, y);
      ctx.lineTo(x + Math.cos(pose.theta) * r * 2, y - Math.sin(pose.theta) * r * 2);
      ctx.stroke();
      canvas.dataset.robot = `${x.toFixed(1)},${y.toFixed(1)}`;
    }
  }

  // --- event log ---------------------------------------------------------------------------------

  function logText(r) {
    switch (r.type) {
      case "state": return `${r.from || "–"} —${r.event}→ ${r.to}`;
      case "say": return `“${r.text}”`;
      case "heard": return `“${r.text}”`;
      case "emotion": return `${r.emotion}  P ${signed(r.pleasure)} A ${signed(r.arousal)} D ${signed(r.dominance)}`;
      case "pose": return `x ${r.x.toFixed(2)} y ${r.y.toFixed(2)} heading ${((r.theta * 180) / Math.PI).toFixed(0)}°`;
      case "motivator": return `${r.event ? `chose ${r.event}` : "chose nothing"}${r.reason ? ` — ${r.reason}` : ""}`;
      default: return JSON.stringify(r);
    }
  }

  function logRow(r) {
    const row = el("li");
    row.dataset.type = r.type;
    row.dataset.seq = r.seq;
    row.append(el("span", "t", fmtClock(r.t)));
    row.append(el("span", "kind", r.type));
    const text = el("span", "text", logText(r));
    if (r.type === "motivator" && r.candidates && r.candidates.length) {
      const list = el("div", "cands");
      for (const c of r.candidates) {
        const classes = ["cand"];
        if (c.event === r.event) classes.push("chosen");
        if (c.eligible === false) classes.push("ineligible");
        const chip = el("span", classes.join(" "), `${c.event} ${Number(c.net).toFixed(3)}`);
        chip.title = `reward ${Number(c.reward).toFixed(3)} · cost ${Number(c.cost).toFixed(3)} · net ${Number(c.net).toFixed(3)}${c.eligible === false ? " · not eligible" : ""}`;
        list.append(chip);
      }
      text.append(list);
    }
    row.append(text);
    return row;
  }

  function logFilter() {
    const types = new Set(
      [...document.querySelectorAll(".log-filters input[type=checkbox]")].filter((c) => c.checked).map((c) => c.dataset.type)
    );
    const words = $("log-text").value.trim().toLowerCase();
    return (r) => types.has(r.type) && (!words || `${r.type} ${logText(r)} ${JSON.stringify(r.candidates || "")}`.toLowerCase().includes(words));
  }

  function renderLog() {
    const keep = logFilter();
    const rows = [];
    for (let i = dash.records.length - 1; i >= 0 && rows.length < LOG_SHOWN; i--) {
      if (keep(dash.records[i])) rows.push(logRow(dash.records[i]));
    }
    $("log").replaceChildren(...rows);
    $("log-count").textContent = `${rows.length} shown of ${dash.records.length}`;
  }

  function logRecord(r) {
    dash.records.push(r);
    if (dash.records.length > LOG_KEEP) dash.records.splice(0, dash.records.length - LOG_KEEP);
    if (dash.syncing) return; // drawn in one go once the backlog is in
    if (!logFilter()(r)) return;
    const log = $("log");
    log.prepend(logRow(r));
    while (log.children.length > LOG_SHOWN) log.lastElementChild.remove();
    $("log-count").textContent = `${log.children.length} shown of ${dash.records.length}`;
  }

  // --- records and the websocket -------------------------------------------------------------

  function handleRecord(r) {
    if (r.seq <= dash.lastSeq) {
      if (!dash.syncing) location.reload(); // a new robot answers on this address: start afresh
      return;
    }
    dash.lastSeq = r.seq;
    dash.t = Math.max(dash.t, r.t);
    switch (r.type) {
      case "state":
        applyStatus({ state: r.to, previous_state: r.from, event: r.event });
        if (!dash.syncing) {
          refreshStatus();
          refreshHealth();
        }
        break;
      case "emotion":
        dash.history.push({ t: r.t, p: r.pleasure, a: r.arousal, d: r.dominance });
        if (dash.history.length > 20000) dash.history.splice(0, 10000);
        applyEmotion(r);
        break;
      case "pose":
        applyPose(r);
        break;
      default:
        break;
    }
    logRecord(r);
    $("top-time").textContent = fmtClock(dash.t);
  }

  function setConnection(state, text) {
    $("conn").dataset.state = state;
    $("conn-text").textContent = text;
  }

  function connect() {
    setConnection("connecting", "connecting");
    const socket = new WebSocket(`${location.protocol === "https:" ? "wss" : "ws"}://${location.host}/api/ws`);
    dash.syncing = true;
    dash.pending = [];
    socket.onopen = () => {
      setConnection("open", "live");
      dash.retry = 500;
    };
    socket.onmessage = (message) => {
      const data = JSON.parse(message.data);
      if (data.type === "hello") onHello(data.status);
      else if (dash.syncing) dash.pending.push(data);
      else handleRecord(data);
    };
    socket.onclose = () => {
      setConnection("closed", `reconnecting in ${(dash.retry / 1000).toFixed(1)} s`);
      setTimeout(connect, dash.retry);
      dash.retry = Math.min(dash.retry * 2, 8000);
    };
  }

  async function onHello(status) {
    applyStatus(status);
    try {
      const backlog = await getJSON(`/api/records?since=${dash.lastSeq}`);
      backlog.forEach(handleRecord);
    } catch (error) {
      say(`could not read the robot's records: ${error.message}`, true);
    }
    dash.pending.forEach(handleRecord);
    dash.pending = [];
    dash.syncing = false;
    renderLog();
    refreshStatus();
  }

  // --- controls ------------------------------------------------------------------------------------

  function wireControls() {
    $("chat-form").addEventListener("submit", async (event) => {
      event.preventDefault();
      const input = $("chat-input");
      const text = input.value.trim();
      if (!text) return;
      try {
        await post("/api/say", { text });
        input.value = "";
        say(`heard: ${text}`);
      } catch (error) {
        say(`not sent: ${error.message}`, true);
      }
    });
    $("emotion-set").addEventListener("click", async () => {
      const name = $("emotion-select").value;
      try {
        await post("/api/emotion/set", { name });
        say(`emotion set to ${name}`);
      } catch (error) {
        say(`emotion not set: ${error.message}`, true);
      }
    });
    $("emotion-switch").addEventListener("change", async (event) => {
      const on = event.target.checked;
      try {
        await post("/api/emotion/switch", { on });
        say(`emotion system switched ${on ? "on" : "off"}`);
      } catch (error) {
        say(`not switched: ${error.message}`, true);
      }
    });
    document.querySelectorAll(".log-filters input").forEach((input) => input.addEventListener("input", renderLog));
    window.addEventListener("resize", () => {
      scheduleDraw();
      if (dash.map) loadMapImage().catch(() => {});
    });
  }

  async function start() {
    wireControls();
    await Promise.all([loadGraph(), loadEmotions()]);
    connect();
    await refreshHealth();
    setInterval(refreshHealth, 1000);
    refreshRoute();
    setInterval(scheduleDraw, 1000);
  }

  start();
})();
