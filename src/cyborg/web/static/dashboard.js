// Cyborg dashboard: plain JavaScript, no build step, nothing loaded from outside the robot.
// Reads the robot's API: /api/ws (live records), /api/status, /api/health, /api/machine,
// /api/graph.svg, /api/emotions, /api/map, /api/route and /api/records; sends commands with POST.
// Pan and zoom of the state machine and the map: svg-pan-zoom (vendored, see svg-pan-zoom.LICENSE).
"use strict";

(() => {
  const $ = (id) => document.getElementById(id);
  const SVGNS = "http://www.w3.org/2000/svg";

  const PLOT_WINDOW = 300; // seconds of robot time in the PAD plot
  const LOG_KEEP = 5000; // records kept for the log
  const LOG_SHOWN = 400; // rows drawn at once
  const TRAIL = 60; // poses kept for the robot's trail
  const READABLE = 15; // px: the height of a graph label's box that "follow" zooms to (about 12 px type)
  const ZOOM_STEP = 1.5; // one click on + or −
  const COLLAPSE_FROM = 60; // a machine with more states opens with its superstates collapsed around the active one
  const EMOTION_COLOURS = {
    neutral: "#a0a7b4",
    elated: "#f5c518",
    loved: "#ff6fae",
    curious: "#3ec7e0",
    dignified: "#a78bfa",
    puzzled: "#ff9f43",
    angry: "#e5484d",
    inhibited: "#5b7bd5",
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
    transitions: {}, // state -> {event: target}, as declared (a superstate's are its own)
    arrowOf: {}, // "state\tevent" -> id of the arrow that shows the transition
    collapsed: new Set(), // superstates drawn as one box
    supers: new Set(), // the superstates' names
    leafCount: 0,
    prototypes: {},
    emotion: null,
    history: [],
    records: [],
    lastDecision: null, // the newest "nothing chosen" decision, while repeats of it fold into its row
    t: 0,
    health: null,
    hasBase: null,
    graphZoom: null,
    map: null,
    mapView: null,
    route: null,
    remaining: null,
    pathState: null,
    pose: null,
    trail: [],
    spaceLabels: [],
    drawQueued: false,
  };
  window.cyborgDashboard = dash; // for the tests and for poking around in the console

  // --- helpers ---------------------------------------------------------------------------

  // A robot serving beyond loopback wants its token on every /api/ request: it comes once in the
  // address the robot printed (…/#token=…), is kept for this tab and taken out of the address bar.
  const TOKEN = (() => {
    const given = new URLSearchParams(location.hash.slice(1)).get("token");
    if (given) {
      sessionStorage.setItem("cyborg-token", given);
      history.replaceState(null, "", location.pathname + location.search);
    }
    return sessionStorage.getItem("cyborg-token");
  })();

  async function api(url, options = {}) {
    const headers = { ...(options.headers || {}) };
    if (TOKEN) headers.Authorization = `Bearer ${TOKEN}`;
    const response = await fetch(url, { ...options, headers });
    if (response.status === 401) {
      say("this robot needs its token: open the address it printed at start (it ends in #token=…)", true);
    }
    return response;
  }

  async function getJSON(url) {
    const response = await api(url, { cache: "no-store" });
    if (!response.ok) throw new Error(`${url}: HTTP ${response.status} ${await response.text()}`);
    return response.json();
  }

  async function post(url, body) {
    const response = await api(url, {
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
    box.title = text;
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
  const num = (v, digits = 4) => (v != null && isFinite(v) ? Number(v).toFixed(digits) : "–");

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

  function svgEl(tag, attributes = {}, text = null) {
    const node = document.createElementNS(SVGNS, tag);
    for (const [key, value] of Object.entries(attributes)) node.setAttribute(key, value);
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

  // Pan and zoom (mouse wheel, drag, double click, and the panel's −/fit/+ buttons) for an SVG.
  // Until the user zooms or pans, the whole drawing stays fitted to its box as the box changes size.
  function makeZoomable(svg, tools, options = {}) {
    let moved = false;
    for (const kind of ["wheel", "mousedown", "touchstart", "dblclick"]) {
      svg.addEventListener(kind, () => { moved = true; }, { passive: true });
    }
    const zoom = window.svgPanZoom(svg, {
      zoomScaleSensitivity: 0.25,
      minZoom: 0.8,
      maxZoom: 12,
      fit: true,
      center: true,
      ...options,
    });
    const refit = () => {
      zoom.resize();
      zoom.fit();
      zoom.center();
    };
    for (const button of tools.querySelectorAll("button[data-zoom]")) {
      button.onclick = () => {
        const what = button.dataset.zoom;
        moved = what !== "fit";
        if (what === "in") zoom.zoomBy(ZOOM_STEP);
        else if (what === "out") zoom.zoomBy(1 / ZOOM_STEP);
        else refit();
      };
    }
    let last = "";
    new ResizeObserver(() => {
      const size = `${svg.clientWidth}x${svg.clientHeight}`;
      if (size === last || !svg.clientWidth || !svg.clientHeight) return;
      last = size;
      if (moved) zoom.resize();
      else refit();
    }).observe(svg);
    zoom.moved = () => moved;
    zoom.markMoved = () => { moved = true; };
    return zoom;
  }

  // --- status and the state machine ------------------------------------------------------

  // The state part of the status: the emotion comes from the emotion records alone (see applyEmotion).
  function applyStatus(status) {
    const before = dash.status.state;
    dash.status = { ...dash.status, ...status };
    const s = dash.status;
    $("top-state").textContent = s.state || "–";
    $("events-state").textContent = s.state || "–";
    renderEventButtons(s.valid_events || []);
    highlightGraph();
    openAroundActive();
    if (s.state !== before && $("graph-follow").checked) requestAnimationFrame(followActive);
  }

  async function refreshStatus() {
    try {
      const status = await getJSON("/api/status");
      $("top-graph").textContent = status.graph || "–";
      $("top-graph").title = status.graph || "";
      applyStatus({ valid_events: status.valid_events, state: status.state,
        previous_state: status.previous_state, event: status.event });
      if (status.problems) {
        dash.problems = { ...status.problems };
        showProblems();
      }
    } catch (error) {
      say(`could not read the status: ${error.message}`, true);
    }
  }

  async function loadGraph() {
    const box = $("graph");
    try {
      const [machine, response, arrows] = await Promise.all([
        getJSON("/api/machine"), api("/api/graph.svg"), getJSON("/api/graph.json"),
      ]);
      if (!response.ok) throw new Error(`/api/graph.svg: HTTP ${response.status} ${await response.text()}`);
      for (const state of machine.states) {
        dash.parents[state.name] = state.parent;
        dash.transitions[state.name] = state.transitions;
        if (!state.leaf) dash.supers.add(state.name);
      }
      for (const [id, pairs] of Object.entries(arrows.edges || {})) {
        for (const [state, event] of pairs) dash.arrowOf[`${state}\t${event}`] = id;
      }
      const text = await response.text();
      box.innerHTML = text.slice(text.indexOf("<svg"));
      const svg = box.querySelector("svg");
      svg.removeAttribute("width");
      svg.removeAttribute("height");
      svg.setAttribute("preserveAspectRatio", "xMidYMid meet");
      dash.graphZoom = makeZoomable(svg, $("graph-tools"), { maxZoom: 15 });
      const leaves = machine.states.filter((s) => s.leaf).length;
      dash.leafCount = leaves;
      $("graph-caption").textContent = `${leaves} states · initial ${machine.initial}`;
      prepareClusters(svg);
      fillSearchList(machine);
      if (response.headers.get("X-Graph-Layout") === "list") { // too big or too slow for Graphviz here
        $("graph-caption").textContent += " · listed, not drawn";
        $("graph-caption").title = box.querySelector("#list > text")?.textContent || "";
      }
      dash.graphLoaded = true;
      highlightGraph();
      openAroundActive();
    } catch (error) {
      box.innerHTML = "";
      box.append(el("p", "muted", `The state machine cannot be drawn: ${error.message}`));
    }
  }

  // Bring an element of the graph into view, zoomed in until its label is readable (never zooms out).
  function focusOn(node) {
    const zoom = dash.graphZoom;
    if (!zoom || !node) return;
    const area = $("graph").querySelector("svg").getBoundingClientRect();
    const label = (node.querySelector("text") || node).getBoundingClientRect();
    // An arrow is read by its event's name: bring that into view (a long arrow's middle may be
    // far from it).
    const box = node.classList.contains("edge") ? label : node.getBoundingClientRect();
    const point = { x: box.x + box.width / 2 - area.x, y: box.y + box.height / 2 - area.y };
    const factor = label.height > 0 ? Math.max(1, READABLE / label.height) : 1;
    if (factor > 1.01) zoom.zoomAtPointBy(factor, point);
    const margin = 0.15;
    const inside = point.x > area.width * margin && point.x < area.width * (1 - margin) &&
      point.y > area.height * margin && point.y < area.height * (1 - margin);
    if (factor > 1.01 || !inside) zoom.panBy({ x: area.width / 2 - point.x, y: area.height / 2 - point.y });
    zoom.markMoved();
  }

  // The active state, or the collapsed superstate that holds it.
  function followActive() {
    const s = dash.status.state;
    if (!s) return;
    const hidden = outermostCollapsed(s);
    focusOn(document.getElementById(hidden ? `super:${hidden}` : `state:${s}`));
  }

  // Zoom so that a superstate's box fills the panel (what a large machine opens on).
  function fitTo(element) {
    const zoom = dash.graphZoom;
    if (!zoom || !element) return;
    zoom.fit();
    zoom.center();
    const area = $("graph").querySelector("svg").getBoundingClientRect();
    const box = element.getBoundingClientRect();
    if (!box.width || !box.height) return;
    const factor = Math.min(area.width / box.width, area.height / box.height) * 0.9;
    const point = { x: box.x + box.width / 2 - area.x, y: box.y + box.height / 2 - area.y };
    zoom.panBy({ x: area.width / 2 - point.x, y: area.height / 2 - point.y });
    if (factor > 1) zoom.zoomAtPointBy(factor, { x: area.width / 2, y: area.height / 2 });
    zoom.markMoved();
  }

  // --- collapse and expand superstates ------------------------------------------------------------

  const ancestorsOf = (name) => {
    const chain = [];
    for (let p = dash.parents[name]; p; p = dash.parents[p]) chain.push(p);
    return chain;
  };

  // The outermost collapsed superstate around ``name`` (not ``name`` itself), if any.
  function outermostCollapsed(name) {
    let found = null;
    for (const p of ancestorsOf(name)) if (dash.collapsed.has(p)) found = p;
    return found;
  }

  // Each cluster gets a card (drawn when it is collapsed) and toggles on a click on its title or card.
  function prepareClusters(svg) {
    dash.collapsed.clear();
    const counts = {}; // superstate -> how many states it holds
    for (const name of Object.keys(dash.parents)) {
      if (!isSuper(name)) for (const p of ancestorsOf(name)) counts[p] = (counts[p] || 0) + 1;
    }
    for (const cluster of svg.querySelectorAll("g.cluster[id^='super:']")) {
      const name = cluster.id.slice("super:".length);
      const frame = cluster.querySelector("path, polygon").getBBox();
      const card = svgEl("g", { class: "card" });
      card.append(svgEl("rect", { x: frame.x, y: frame.y, width: frame.width, height: frame.height, rx: 8 }));
      const count = counts[name] || 0;
      const size = Math.max(12, Math.min(frame.height * 0.22, (frame.width * 0.9) / (0.6 * (name.length + 2))));
      const title = svgEl("text", { x: frame.x + frame.width / 2, y: frame.y + frame.height / 2, "font-size": size.toFixed(1), "text-anchor": "middle" }, `▸ ${name}`);
      const detail = svgEl("text", { class: "detail", x: frame.x + frame.width / 2, y: frame.y + frame.height / 2 + size * 0.9,
        "font-size": (size * 0.5).toFixed(1), "text-anchor": "middle" }, `${count} states`);
      card.append(title, detail);
      card.dataset.states = String(count);
      cluster.append(card);
      const toggle = (event) => {
        event.stopPropagation();
        setCollapsed(name, !dash.collapsed.has(name));
      };
      card.addEventListener("click", toggle);
      const heading = cluster.querySelector(":scope > text");
      if (heading) {
        heading.addEventListener("click", toggle);
        heading.classList.add("toggle");
      }
    }
  }

  function setCollapsed(name, collapsed) {
    if (collapsed) dash.collapsed.add(name);
    else dash.collapsed.delete(name);
    applyCollapse();
  }

  // Hide what collapsed superstates hold: their states, inner superstates and inner arrows.
  function applyCollapse() {
    const svg = $("graph").querySelector("svg");
    if (!svg) return;
    const hiddenInside = (name) => ancestorsOf(name).some((p) => dash.collapsed.has(p));
    for (const node of svg.querySelectorAll("g.node[id^='state:']")) {
      node.classList.toggle("folded", hiddenInside(node.id.slice(6)));
    }
    for (const cluster of svg.querySelectorAll("g.cluster[id^='super:']")) {
      const name = cluster.id.slice(6);
      cluster.classList.toggle("folded", hiddenInside(name));
      cluster.classList.toggle("collapsed", dash.collapsed.has(name));
    }
    for (const edge of svg.querySelectorAll("g.edge")) {
      const tail = (edge.querySelector("title")?.textContent || "").split("->")[0];
      edge.classList.toggle("folded", tail in dash.parents && hiddenInside(tail));
    }
    $("graph-caption").dataset.collapsed = String(dash.collapsed.size);
    highlightGraph();
  }

  // Collapse every superstate except those around ``state``, and show the innermost of those.
  function collapseAround(state) {
    const keep = new Set(ancestorsOf(state));
    dash.collapsed = new Set(Object.keys(dash.transitions).filter((name) => isSuper(name) && !keep.has(name)));
    applyCollapse();
    const inner = ancestorsOf(state)[0];
    requestAnimationFrame(() => {
      if (inner) fitTo(document.getElementById(`super:${inner}`));
      else dash.graphZoom?.fit(); // a state at the top level: the whole machine, its superstates as cards
    });
  }

  const isSuper = (name) => dash.supers.has(name);

  // A large machine opens collapsed around the active state, once the graph and the state are known.
  function openAroundActive() {
    if (dash.opened || !dash.graphLoaded || !dash.status.state) return;
    dash.opened = true;
    if (dash.leafCount > COLLAPSE_FROM) collapseAround(dash.status.state);
  }

  function expandAll() {
    dash.collapsed.clear();
    applyCollapse();
  }

  function collapseAll() {
    dash.collapsed = new Set(Object.keys(dash.transitions).filter(isSuper));
    applyCollapse();
  }

  // --- search ---------------------------------------------------------------------------------------

  function fillSearchList(machine) {
    const list = $("graph-search-list");
    const names = new Set();
    for (const state of machine.states) {
      names.add(state.name);
      for (const event of Object.keys(state.transitions)) names.add(event);
    }
    list.replaceChildren(...[...names].sort().slice(0, 5000).map((name) => el("option", "", name)));
  }

  // Find a state (its name, else the first name containing the words) or an event, open the
  // superstates around it and bring it into view.
  function search(text) {
    const svg = $("graph").querySelector("svg");
    const words = text.trim();
    svg?.querySelectorAll(".found").forEach((node) => node.classList.remove("found"));
    if (!svg || !words) return null;
    const lower = words.toLowerCase();
    const states = Object.keys(dash.parents);
    const state = states.find((s) => s === words) || states.find((s) => s.toLowerCase() === lower) ||
      states.find((s) => s.toLowerCase().includes(lower));
    const pairs = Object.keys(dash.arrowOf).filter((key) => key.split("\t")[1].toLowerCase() === lower);
    let target = null;
    if (state && !(pairs.length && state.toLowerCase() !== lower)) {
      for (const p of ancestorsOf(state)) dash.collapsed.delete(p);
      applyCollapse();
      target = document.getElementById(isSuper(state) ? `super:${state}` : `state:${state}`);
    } else if (pairs.length) {
      for (const key of pairs) {
        for (const p of ancestorsOf(key.split("\t")[0])) dash.collapsed.delete(p);
      }
      applyCollapse();
      const edges = [...new Set(pairs.map((key) => dash.arrowOf[key]))].map((id) => document.getElementById(id)).filter(Boolean);
      edges.forEach((edge) => edge.classList.add("found"));
      target = edges[0] || null;
    }
    if (target) {
      target.classList.add("found");
      focusOn(target);
      say(`found ${words}`);
    } else {
      say(`no state or event called ${words}`, true);
    }
    return target ? target.id : null;
  }

  function highlightGraph() {
    const box = $("graph");
    const s = dash.status;
    box.querySelectorAll(".active, .active-parent, .active-inside, .last, .last-inside, .valid").forEach((node) => {
      node.classList.remove("active", "active-parent", "active-inside", "last", "last-inside", "valid");
    });
    if (!s.state) return;
    const node = document.getElementById(`state:${s.state}`);
    if (node) node.classList.add("active");
    // In a parallel state every region's state is in control (the lanes come with /api/health).
    for (const lane of dash.health?.regions || []) {
      if (lane.state) document.getElementById(`state:${lane.state}`)?.classList.add("active");
    }
    for (let parent = dash.parents[s.state]; parent; parent = dash.parents[parent]) {
      const cluster = document.getElementById(`super:${parent}`);
      if (cluster) cluster.classList.add("active-parent");
    }
    const hidden = outermostCollapsed(s.state); // the box the active state is folded into
    box.querySelectorAll(".card text.detail").forEach((text) => {
      text.textContent = `${text.parentNode.dataset.states} states`;
    });
    if (hidden) {
      const cluster = document.getElementById(`super:${hidden}`);
      cluster?.classList.add("active-inside");
      const detail = cluster?.querySelector(".card text.detail");
      if (detail) detail.textContent = `${detail.parentNode.dataset.states} states · active: ${s.state}`;
    }
    // The transitions the active state (or a superstate around it) can take now.
    for (let from = s.state; from; from = dash.parents[from]) {
      for (const event of Object.keys(dash.transitions[from] || {})) {
        document.getElementById(dash.arrowOf[`${from}\t${event}`])?.classList.add("valid");
      }
    }
    // The transition may belong to the state left or to a superstate around it.
    for (let from = s.previous_state; from && s.event; from = dash.parents[from]) {
      const edge = document.getElementById(dash.arrowOf[`${from}\t${s.event}`]);
      if (edge) {
        edge.classList.add("last");
        const folded = edge.classList.contains("folded") && outermostCollapsed(from);
        if (folded) document.getElementById(`super:${folded}`)?.classList.add("last-inside");
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

  // In a parallel state: one lane per region, highest priority first, with what it holds and what is muted.
  function renderRegions(regions) {
    const box = $("health-regions");
    box.hidden = regions.length === 0;
    box.replaceChildren();
    for (const lane of regions) {
      const row = el("div", `lane${lane.muted.length ? " muted-lane" : ""}`);
      row.dataset.region = lane.region;
      row.append(el("span", "lane-name", `${lane.region} (priority ${lane.priority})`));
      row.append(el("b", "lane-state", lane.state || "–"));
      if (lane.seconds_in_state != null) row.append(el("span", "muted", ` ${lane.seconds_in_state.toFixed(0)} s`));
      if (lane.holds.length) row.append(el("span", "lane-holds", ` holds ${lane.holds.join(", ")}`));
      if (lane.muted.length) row.append(el("span", "lane-muted bad", ` muted: ${lane.muted.join(", ")}`));
      box.append(row);
    }
  }

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
    showEmotionSwitch(health.emotion_enabled);
    showStorage(health.storage);
    showBlocked(health.blocked);
    $("health-caption").textContent =
      `${health.active_state || "–"} for ${health.seconds_in_state.toFixed(0)} s · goal ${health.goal_status || "none"}`;

    const stats = $("health-stats");
    stats.replaceChildren();
    const labels = {
      events_received: "events", events_invalid: "invalid", events_overflow: "overflow", events_stale: "stale", events_superseded: "superseded",
      handovers: "handovers", preempt_timeouts: "preempt timeouts",
      connect_failures: "connect failures", succeeded_fallbacks: "fallbacks",
      retries_delayed: "retries paused", resource_grants: "grants", resource_mutes: "mutes",
    };
    const bad = new Set(["events_overflow", "events_stale", "preempt_timeouts", "connect_failures", "retries_delayed"]);
    // The counters that say something: events and handovers always, the others once not zero
    // (the tooltip lists every one), so the event log keeps its room.
    const always = new Set(["events_received", "handovers"]);
    if ((health.regions || []).length) ["resource_grants", "resource_mutes"].forEach((key) => always.add(key));
    const zero = [];
    for (const [key, value] of Object.entries(health.stats)) {
      if (!value && !always.has(key)) {
        zero.push(labels[key] || key);
        continue;
      }
      const chip = el("span", `stat${bad.has(key) && value ? " bad" : ""}`, `${labels[key] || key} `);
      chip.append(el("b", "", String(value)));
      stats.append(chip);
    }
    stats.title = zero.length ? `0: ${zero.join(", ")}` : "";

    const lanesBefore = JSON.stringify(dash.lanes || []);
    renderRegions(health.regions || []);
    dash.lanes = (health.regions || []).map((lane) => lane.state);
    if (JSON.stringify(dash.lanes) !== lanesBefore && dash.status) highlightGraph();

    // A module that reports when its last feedback came shows its age; the others show when they were active.
    const withFeedback = health.modules.some((m) => m.seconds_since_feedback != null);
    $("health-table").querySelector("th:last-child").textContent = withFeedback ? "last feedback" : "last active";
    const body = $("health-table").querySelector("tbody");
    body.replaceChildren();
    const modules = [...health.modules].sort((x, y) => (y.active - x.active) || (x.states.length ? 0 : 1) - (y.states.length ? 0 : 1));
    for (const m of modules) {
      const row = el("tr", m.active ? "active" : "");
      row.dataset.module = m.name;
      const name = el("td", "", m.name);
      name.title = m.name;
      row.append(name);
      // A module that serves many states (a generated machine) names a few and counts the rest.
      const named = m.states.length > 6 ? `${m.states.slice(0, 4).join(", ")} +${m.states.length - 4} more` : m.states.join(", ");
      const states = el("td", "muted states", named || "–");
      states.title = m.states.length > 200 ? `${m.states.slice(0, 200).join(", ")} …` : m.states.join(", ");
      row.append(states);
      const goal = el("td");
      if (m.goal_status) goal.append(el("span", `goal goal-${m.goal_status}`, m.goal_status.toLowerCase()));
      else goal.append(el("span", "muted", m.states.length ? "idle" : "–"));
      row.append(goal);
      const active = m.active ? `for ${health.seconds_in_state.toFixed(0)} s` : (m.states.length ? fmtAgo(m.seconds_since_active) : "");
      const since = el("td", "since", m.seconds_since_feedback != null ? fmtAgo(m.seconds_since_feedback) : active);
      since.title = m.seconds_since_feedback != null
        ? `last feedback ${fmtAgo(m.seconds_since_feedback)}${active ? ` · active ${active}` : ""}`
        : (active ? `active ${active}` : "");
      row.append(since);
      body.append(row);
    }

    if (health.has_base !== dash.hasBase) {
      dash.hasBase = health.has_base;
      if (health.has_base) loadMap();
      else showNoBase();
    }
    scheduleDraw();
  }

  // A module callback that blocked the robot's event loop (everything here stood still meanwhile):
  // shown for a minute after it ended, naming the callback and its module; the tooltip has the fix.
  function showBlocked(blocked) {
    const box = $("blocked-warning");
    const recent = Boolean(blocked && (blocked.ongoing || blocked.seconds_ago < 60));
    if (recent) {
      const who = blocked.module ? `${blocked.callback} (${blocked.module})` : blocked.callback;
      $("blocked-reason").textContent = `${who} ${blocked.seconds.toFixed(1)} s`;
      box.title = `${who} at ${blocked.where} held the robot's event loop for ${blocked.seconds.toFixed(1)} s: ` +
        `the controller, the other modules and this page stood still` +
        (blocked.stopped ? " (the watchdog stopped that call to keep the controller's handover deadline)" : "") +
        `. Fix: ${blocked.fix}`;
    }
    box.hidden = !recent;
  }

  // What modules cannot fix themselves (no sound device, a base that does not answer): a warning
  // naming the first, the tooltip every one with its fix; gone when each module says it is over.
  function showProblems() {
    const box = $("problems-warning");
    const lines = [];
    for (const [module, open] of Object.entries(dash.problems || {})) {
      for (const p of open) lines.push({ module, ...p });
    }
    if (lines.length) {
      const first = lines[0];
      $("problems-reason").textContent = lines.length > 1
        ? `${first.module}: ${first.problem} (+${lines.length - 1} more)` : `${first.module}: ${first.problem}`;
      box.title = lines.map((p) => `${p.module}: ${p.problem}${p.fix ? `. Fix: ${p.fix}` : ""}`).join("\n");
    }
    box.hidden = lines.length === 0;
  }

  // Whether the robot's data is saved: a warning with the reason and the fix while it is not
  // (the robot goes on in memory), a message once it is saved again; nothing where not known (ROS).
  function showStorage(storage) {
    const box = $("storage-warning");
    const unsaved = Boolean(storage && storage.saved === false);
    if (unsaved) {
      const reason = String(storage.problem || "writes fail").split(": ").pop();
      $("storage-reason").textContent = reason;
      const what = (storage.unsaved || []).join(" and ") || "its data";
      box.title = `${storage.problem}. The robot goes on in memory (${what} not saved, ` +
        `${storage.failed_writes} failed writes) and saves once writes work again. Fix: ${storage.fix}`;
    } else if (!box.hidden) {
      say(`saving again: the robot's data is written to ${storage ? storage.path : "its data folder"}`);
    }
    box.hidden = !unsaved;
  }

  // The flight recorder: on, or stopped and why (the robot runs on); marks and the look back need it.
  async function refreshRecorder() {
    let status;
    try {
      status = await getJSON("/api/recorder");
    } catch (error) {
      return;
    }
    const pill = $("recorder"), on = Boolean(status.recording);
    $("recorder-state").textContent = on ? "on" : status.state === "failed" ? "stopped" : "off";
    pill.classList.toggle("alert", status.state === "failed");
    pill.title = on ? `recording to ${status.file}` : status.problem || "this robot is not recording";
    $("mark").disabled = !on;
    $("lookback").hidden = !on;
  }

  async function markNow(event) {
    event.preventDefault();
    const box = $("mark-note");
    try {
      const answer = await post("/api/mark", { note: box.value || "mark" });
      box.value = "";
      say(`marked: ${answer.marked}`);
    } catch (error) {
      say(error.message, true);
    }
  }

  // true / false, or null where the robot cannot tell (the ROS API node has seen no on/off message yet).
  function showEmotionSwitch(enabled) {
    const sw = $("emotion-switch");
    if (document.activeElement !== sw) {
      sw.indeterminate = enabled == null;
      sw.checked = enabled !== false;
    }
    $("emotion-switch-state").textContent =
      enabled == null ? "on/off not known yet" : enabled ? "" : "switched off";
  }

  // --- emotion -------------------------------------------------------------------------------

  function applyEmotion(r) {
    const current = { name: r.emotion, p: Number(r.pleasure), a: Number(r.arousal), d: Number(r.dominance) };
    dash.emotion = current;
    const colour = emotionColour(current.name, current.p, current.a);
    $("top-emotion").textContent = withAliases(current.name);
    $("top-emotion").style.color = colour;
    const name = $("emotion-name");
    name.textContent = withAliases(current.name);
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
    const pad = { l: 28, r: 8, t: 8, b: 16 };
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
    // Minute ticks, thinned out so that their labels never touch.
    const step = window_ <= 60 ? 15 : 60 * Math.max(1, Math.ceil((window_ / 60) * 34 / Math.max(1, w - pad.l - pad.r)));
    for (let ago = 0; ago <= window_; ago += step) {
      const label = ago === 0 ? "now" : step < 60 ? `-${ago}s` : `-${ago / 60}m`;
      const at = x(now - ago);
      if (ago > 0 && at < pad.l + 10) continue; // would sit on the axis labels
      ctx.fillText(label, Math.min(Math.max(at, pad.l + 12), w - pad.r - 12), h - pad.b + 3);
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
    const size = Math.max(10, Math.min(w, h) - 24);
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
    // A label box moved inside the canvas, so no name is cut at its edge.
    const inside = (box) => ({ ...box, x: Math.min(Math.max(box.x, 1), w - box.w - 1), y: Math.min(Math.max(box.y, 1), h - box.h - 1) });
    ctx.textBaseline = "middle";
    const labels = [];
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
      const boxes = spots.map(([dx, dy]) => inside({ x: x(p) + dx - tw / 2, y: y(a) + dy - 6, w: tw, h: 12 }));
      const box = boxes.find((b) => !overlaps(b)) || boxes[0];
      placed.push(box);
      labels.push({ name, ...box });
      ctx.globalAlpha = 1;
      ctx.fillStyle = current ? "#ffffff" : "#aeb5c2";
      ctx.fillText(name, box.x + tw / 2, box.y + 6);
    }
    dash.spaceLabels = { width: w, height: h, labels };
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

  // "elated (happy)": the thesis's name with the words its table gives in brackets (aliases).
  function withAliases(name) {
    const aliases = Object.entries(dash.emotionAliases || {}).filter(([, target]) => target === name).map(([alias]) => alias);
    return aliases.length ? `${name} (${aliases.sort().join(", ")})` : name;
  }

  async function loadEmotions() {
    try {
      const data = await getJSON("/api/emotions");
      dash.prototypes = data.prototypes || {};
      dash.emotionAliases = data.aliases || {};
    } catch (error) {
      say(`could not read the emotion prototypes: ${error.message}`, true);
    }
    const select = $("emotion-select");
    select.replaceChildren();
    for (const name of ["neutral", ...Object.keys(dash.prototypes).sort()]) {
      const option = el("option", "", withAliases(name));
      option.value = name;
      select.append(option);
    }
    const e = dash.emotion;  // shown before the aliases were known: show it again with them
    if (e) applyEmotion({ emotion: e.name, pleasure: e.p, arousal: e.a, dominance: e.d });
    scheduleDraw();
  }

  // --- map -------------------------------------------------------------------------------------
  // An SVG: the grid image, keep-out zones, route and trail live in metres inside the pan/zoom
  // viewport; places, their names and the robot are drawn on top in screen pixels, so they keep
  // their size at any zoom, and a name that would cover another is left out until zoomed in.

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
      buildMap(info);
      await loadMapImage();
      $("map-message").hidden = true;
      $("map-caption").textContent = `${info.source || "map"} · ${info.locations.length} places`;
      $("map-caption").title = `${info.size_m[0].toFixed(1)} × ${info.size_m[1].toFixed(1)} m, ${info.resolution} m per cell`;
    } catch (error) {
      $("map-message").hidden = false;
      $("map-message").firstElementChild.textContent = `The map cannot be shown: ${error.message}`;
    }
  }

  function buildMap(info) {
    const svg = $("map");
    if (dash.mapView) dash.mapView.zoom.destroy();
    svg.replaceChildren();
    const [width, height] = info.size_m;
    const [x0, y0] = info.origin;
    // World coordinates: metres from the map's upper-left corner, y down.
    const wx = (x) => x - x0;
    const wy = (y) => y0 + height - y;
    svg.setAttribute("viewBox", `0 0 ${width} ${height}`);
    const world = svgEl("g", { id: "map-world", class: "svg-pan-zoom_viewport" });
    const image = svgEl("image", { class: "grid-image", preserveAspectRatio: "none" });
    const zones = svgEl("g", { class: "zones" });
    for (const zone of info.keep_out) {
      const points = zone.corners.map(([x, y]) => `${wx(x)},${wy(y)}`).join(" ");
      const shape = svgEl(zone.line ? "polyline" : "polygon", { points, class: zone.line ? "keep-out line" : "keep-out" });
      shape.append(svgEl("title", {}, `keep out${zone.name ? `: ${zone.name}` : ""}`));
      zones.append(shape);
    }
    const trail = svgEl("polyline", { class: "trail" });
    const route = svgEl("polyline", { class: "route" });
    const remaining = svgEl("polyline", { class: "route-ahead" });
    world.append(image, zones, trail, route, remaining);
    const overlay = svgEl("g", { id: "map-overlay" });
    const places = info.locations.map((place) => {
      const group = svgEl("g", { class: "place" });
      group.dataset.name = place.name;
      const marker = svgEl("path", { class: "place-marker", d: "M0,-4 L4,0 L0,4 L-4,0 Z" });
      marker.append(svgEl("title", {}, `${place.name} (${place.x.toFixed(1)}, ${place.y.toFixed(1)})`));
      const label = svgEl("g", { class: "place-label" });
      const back = svgEl("rect", { height: 14, rx: 2 });
      const text = svgEl("text", { x: 3, y: 7 }, place.name);
      label.append(back, text);
      group.append(marker, label);
      overlay.append(group);
      return { place, group, marker, label, back, text, width: 0 };
    });
    const goal = svgEl("circle", { class: "goal", r: 5, visibility: "hidden" });
    const robot = svgEl("g", { class: "robot", visibility: "hidden" });
    const body = svgEl("circle", { r: 6 });
    const heading = svgEl("line", { x1: 0, y1: 0, x2: 12, y2: 0 });
    robot.append(body, heading);
    overlay.append(goal, robot);
    svg.append(world, overlay);
    for (const p of places) {
      p.width = p.text.getComputedTextLength() + 6;
      p.back.setAttribute("width", p.width);
    }
    dash.mapView = { svg, world, image, trail, route, remaining, overlay, places, goal, robot, body, heading, wx, wy, loaded: 0 };
    dash.mapView.zoom = makeZoomable(svg, $("map-tools"), {
      viewportSelector: world,
      maxZoom: 40,
      onUpdatedCTM: () => {
        placeOverlay();
        clearTimeout(dash.mapView.sharpen);
        dash.mapView.sharpen = setTimeout(() => loadMapImage().catch(() => {}), 250);
      },
    });
    scheduleDraw();
  }

  // The grid image at about the pixel size it is shown at (walls kept), sharper as one zooms in.
  async function loadMapImage() {
    const view = dash.mapView;
    const m = dash.map;
    if (!view || !m) return;
    const { realZoom } = view.zoom.getSizes();
    const ratio = window.devicePixelRatio || 1;
    const full = Math.max(...m.cells);
    const shown = Math.max(...m.size_m) * realZoom * ratio;
    const wanted = Math.min(full, Math.max(100, 2 ** Math.ceil(Math.log2(shown))));
    if (view.loaded >= wanted || view.loading >= wanted) return;
    view.loading = wanted;
    try {
      const response = await api(`${m.image}?max=${wanted}`, { cache: "no-store" });
      if (!response.ok) throw new Error(`${m.image}: HTTP ${response.status} ${await response.text()}`);
      const perPixel = Number(response.headers.get("X-Cells-Per-Pixel") || "1");
      const url = URL.createObjectURL(await response.blob());
      if (view !== dash.mapView || wanted < view.loaded) return;
      // Each image pixel covers perPixel x perPixel cells; the image's lower-left corner is the origin.
      const [cols, rows] = m.cells;
      const w = Math.ceil(cols / perPixel) * perPixel * m.resolution;
      const h = Math.ceil(rows / perPixel) * perPixel * m.resolution;
      const old = view.image.getAttribute("href");
      view.image.setAttribute("href", url);
      view.image.setAttribute("x", "0");
      view.image.setAttribute("y", String(rows * m.resolution - h));
      view.image.setAttribute("width", String(w));
      view.image.setAttribute("height", String(h));
      if (old) URL.revokeObjectURL(old);
      view.loaded = wanted;
    } finally {
      if (view.loading === wanted) view.loading = 0;
    }
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

  // What lives in metres: route and trail.
  function drawMap() {
    const view = dash.mapView;
    if (!view || !dash.map) return;
    const points = (list) => (list || []).map((q) => `${view.wx(q[0])},${view.wy(q[1])}`).join(" ");
    view.trail.setAttribute("points", points(dash.trail.map((q) => [q.x, q.y])));
    const route = dash.route && dash.route.length ? dash.route : null;
    view.route.setAttribute("points", points(route));
    view.remaining.setAttribute("points", route ? points(dash.remaining && dash.remaining.length ? dash.remaining : route) : "");
    placeOverlay();
  }

  // What lives in screen pixels: places, names, the goal and the robot.
  function placeOverlay() {
    const view = dash.mapView;
    if (!view) return;
    const { realZoom } = view.zoom.getSizes();
    const pan = view.zoom.getPan();
    const sx = (x) => pan.x + view.wx(x) * realZoom;
    const sy = (y) => pan.y + view.wy(y) * realZoom;
    const width = view.svg.clientWidth;
    const height = view.svg.clientHeight;
    const placed = [];
    const overlaps = (b) => placed.some((o) => b.x < o.x + o.w && o.x < b.x + b.w && b.y < o.y + o.h && o.y < b.y + b.h);
    const pose = dash.pose;
    if (pose) {
      const x = sx(pose.x);
      const y = sy(pose.y);
      const r = Math.max(6, 0.35 * realZoom);
      view.robot.setAttribute("visibility", "visible");
      view.robot.setAttribute("transform", `translate(${x.toFixed(1)} ${y.toFixed(1)}) rotate(${(-pose.theta * 180) / Math.PI})`);
      view.body.setAttribute("r", r.toFixed(1));
      view.heading.setAttribute("x2", (2 * r).toFixed(1));
      view.svg.dataset.robot = `${x.toFixed(1)},${y.toFixed(1)}`;
      placed.push({ x: x - r, y: y - r, w: 2 * r, h: 2 * r });
    }
    const route = dash.route;
    if (route && route.length) {
      const [gx, gy] = route[route.length - 1];
      view.goal.setAttribute("visibility", "visible");
      view.goal.setAttribute("cx", sx(gx).toFixed(1));
      view.goal.setAttribute("cy", sy(gy).toFixed(1));
    } else {
      view.goal.setAttribute("visibility", "hidden");
    }
    for (const p of view.places) {
      p.x = sx(p.place.x);
      p.y = sy(p.place.y);
      p.group.setAttribute("transform", `translate(${p.x.toFixed(1)} ${p.y.toFixed(1)})`);
      placed.push({ x: p.x - 4, y: p.y - 4, w: 8, h: 8 });
    }
    let hidden = 0;
    for (const p of view.places) {
      const tw = p.width;
      const spots = [[6, -7], [-6 - tw, -7], [-tw / 2, -20], [-tw / 2, 6]];
      const boxes = spots.map(([dx, dy]) => ({ x: p.x + dx, y: p.y + dy, w: tw, h: 14, dx, dy }));
      const onScreen = p.x >= 0 && p.x <= width && p.y >= 0 && p.y <= height;
      const fits = (b) => b.x >= 0 && b.y >= 0 && b.x + b.w <= width && b.y + b.h <= height && !overlaps(b);
      const box = onScreen ? boxes.find(fits) : null;
      if (box) {
        placed.push(box);
        p.label.setAttribute("visibility", "visible");
        p.label.setAttribute("transform", `translate(${box.dx.toFixed(1)} ${box.dy.toFixed(1)})`);
      } else {
        p.label.setAttribute("visibility", "hidden");
        if (onScreen) hidden++;
      }
    }
    view.svg.dataset.hiddenLabels = String(hidden);
    const hint = hidden ? `${hidden} ${hidden === 1 ? "name" : "names"} hidden, zoom in` : "";
    if ($("map-hint").textContent !== hint) $("map-hint").textContent = hint;
  }

  // --- event log ---------------------------------------------------------------------------------

  const isIdleDecision = (r) => r.type === "motivator" && !r.event;
  const reasonKey = (r) => String(r.reason || "").replace(/-?\d+(\.\d+)?/g, "#");

  // The rule the motivator ranks eligible candidates (reward > cost and > 0) by: the record's, else the config's.
  function motivatorRule(r) {
    return r.rule || r.selection || (dash.health && dash.health.motivator && dash.health.motivator.selection) || null;
  }

  function logText(r) {
    switch (r.type) {
      case "state": return `${r.from || "–"} —${r.event}→ ${r.to}`;
      case "say": return `“${r.text}”`;
      case "heard": return `“${r.text}”`;
      case "recognised": return `“${r.text || "…"}” ${Math.round(r.confidence * 100)} %${r.accepted ? "" : " (rejected)"}`;
      case "emotion": return `${r.emotion}  P ${signed(r.pleasure)} A ${signed(r.arousal)} D ${signed(r.dominance)}`;
      case "pose": return `x ${r.x.toFixed(2)} y ${r.y.toFixed(2)} heading ${((r.theta * 180) / Math.PI).toFixed(0)}°`;
      case "problems":
        return r.open.length
          ? `${r.module}: ${r.open.map((p) => p.problem + (p.fix ? ` (fix: ${p.fix})` : "")).join("; ")}`
          : `${r.module}: no problem left`;
      case "motivator":
        if (r.event) return `chose ${r.event}${r.reason ? ` — ${r.reason}` : ""}`;
        return `nothing chosen: ${r.reason || "no reason given"}`;
      default: return JSON.stringify(r);
    }
  }

  function candidateChips(r) {
    const rule = motivatorRule(r);
    const key = rule === "net" ? "net" : "reward";
    const candidates = [...(Array.isArray(r.candidates) ? r.candidates : [])];
    candidates.sort((x, y) => (y.event === r.event) - (x.event === r.event) || (Number(y[key]) || 0) - (Number(x[key]) || 0));
    const list = el("div", "cands");
    const heading = el("span", "rule", rule ? `by ${rule}, among reward > cost, > 0:` : "candidates:");
    heading.title = rule === "net"
      ? "the eligible candidate (reward > cost and > 0) with the largest reward - cost wins"
      : rule ? `the eligible candidate (reward > cost and > 0) with the largest ${rule} wins` : "";
    list.append(heading);
    for (const c of candidates) {
      const chosen = r.event != null && c.event === r.event;
      const eligible = c.eligible !== undefined ? c.eligible !== false : Number(c.reward) > Number(c.cost);
      const chip = el("span", `cand${chosen ? " chosen" : ""}${eligible ? "" : " ineligible"}`);
      chip.dataset.event = c.event;
      if (chosen) chip.append(el("span", "mark", "✓ "));
      if (!eligible) chip.append(el("span", "why", "✗ "));
      chip.append(el("b", "", c.event));
      chip.append(` reward ${num(c.reward)} · cost ${num(c.cost)} · net ${num(c.net)}`);
      chip.title = `${c.event}: reward ${num(c.reward, 5)} · cost ${num(c.cost, 5)} · net ${num(c.net, 5)}` +
        (chosen ? " · chosen" : eligible ? "" : " · not eligible: its cost is not below its reward");
      list.append(chip);
    }
    return list;
  }

  function logRow(r) {
    const row = el("li");
    row.dataset.type = r.type;
    row.dataset.seq = r.seq;
    if (r.type === "recognised" && !r.accepted) row.dataset.rejected = "yes"; // greyed: the robot did not believe it
    const t = el("span", "t", fmtClock(r.t));
    row.append(t);
    row.append(el("span", "kind", r.type));
    const text = el("span", "text");
    const withChips = r.type === "motivator" && Array.isArray(r.candidates) && r.candidates.length > 0;
    // A choice shows its candidates as chips; its reason says the same in words, so it goes to the tooltip.
    const line = el("span", "line", withChips && r.event ? `chose ${r.event}` : logText(r));
    line.title = logText(r);
    text.append(line);
    if (r.type === "motivator") {
      row.dataset.chosen = r.event ? "yes" : "no";
      if (r.repeats > 1) {
        const times = el("span", "repeats", `×${r.repeats}`);
        times.title = `${r.repeats} decisions like this from ${fmtClock(r.first_t)} to ${fmtClock(r.t)}`;
        t.append(times);
      }
      if (withChips) text.append(candidateChips(r));
    }
    row.append(text);
    return row;
  }

  function logFilter() {
    const types = new Set(
      [...document.querySelectorAll(".log-filters input[type=checkbox]")].filter((c) => c.checked).map((c) => c.dataset.type)
    );
    const words = $("log-text").value.trim().toLowerCase();
    // The motivator's "nothing chosen" decisions have their own box (off at first): they come every few seconds.
    return (r) => (isIdleDecision(r) ? types.has("nothing") : types.has(r.type)) && (!words || `${r.type} ${logText(r)} ${JSON.stringify(r.candidates || "")}`.toLowerCase().includes(words));
  }

  // "12 shown of 40 · 85 nothing chosen": the folded decisions count each one they stand for.
  function showLogCount(shown) {
    let idle = 0;
    for (const r of dash.records) if (isIdleDecision(r)) idle += r.repeats || 1;
    const hidden = !document.querySelector('.log-filters input[data-type="nothing"]').checked;
    $("log-count").textContent = `${shown} shown of ${dash.records.length}` +
      (idle && hidden ? ` · ${idle} nothing chosen (hidden)` : "");
    $("log-count").dataset.idle = String(idle);
  }

  function renderLog() {
    const keep = logFilter();
    const rows = [];
    for (let i = dash.records.length - 1; i >= 0 && rows.length < LOG_SHOWN; i--) {
      if (keep(dash.records[i])) rows.push(logRow(dash.records[i]));
    }
    $("log").replaceChildren(...rows);
    showLogCount(rows.length);
  }

  // The motivator decides every few seconds; a run of "nothing chosen" for the same reason (numbers
  // aside) is one row that counts its repeats, until anything but an emotion or pose comes between.
  function foldDecision(r) {
    const last = dash.lastDecision;
    if (!isIdleDecision(r)) {
      if (r.type !== "emotion" && r.type !== "pose") dash.lastDecision = null;
      return false;
    }
    if (!last || reasonKey(last) !== reasonKey(r)) {
      dash.lastDecision = r;
      return false;
    }
    const oldSeq = last.seq;
    last.repeats = (last.repeats || 1) + 1;
    if (last.first_t == null) last.first_t = last.t;
    Object.assign(last, { t: r.t, seq: r.seq, reason: r.reason, candidates: r.candidates });
    const index = dash.records.lastIndexOf(last);
    if (index >= 0) dash.records.splice(index, 1);
    dash.records.push(last);
    if (!dash.syncing) {
      const old = $("log").querySelector(`li[data-seq="${oldSeq}"]`);
      if (old) old.remove();
      if (logFilter()(last)) $("log").prepend(logRow(last));
      showLogCount($("log").children.length);
    }
    return true;
  }

  function logRecord(r) {
    if (foldDecision(r)) return;
    dash.records.push(r);
    if (dash.records.length > LOG_KEEP) dash.records.splice(0, dash.records.length - LOG_KEEP);
    if (dash.syncing) return; // drawn in one go once the backlog is in
    if (!logFilter()(r)) return;
    const log = $("log");
    log.prepend(logRow(r));
    while (log.children.length > LOG_SHOWN) log.lastElementChild.remove();
    showLogCount(log.children.length);
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
      case "problems":
        dash.problems = dash.problems || {};
        if (r.open.length) dash.problems[r.module] = r.open;
        else delete dash.problems[r.module];
        showProblems();
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
    const query = TOKEN ? `?token=${encodeURIComponent(TOKEN)}` : ""; // a browser's websocket takes no headers
    const socket = new WebSocket(`${location.protocol === "https:" ? "wss" : "ws"}://${location.host}/api/ws${query}`);
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
    const { emotion, pleasure, arousal, dominance, ...rest } = status;
    applyStatus(rest);
    // The emotion as it was when the socket opened; the emotion records after it take over from here.
    if (emotion != null) applyEmotion({ emotion, pleasure, arousal, dominance });
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
        const reply = await post("/api/emotion/set", { name });
        say(reply.warning ? `emotion set to ${name}, but ${reply.warning}` : `emotion set to ${name}`, Boolean(reply.warning));
      } catch (error) {
        say(`emotion not set: ${error.message}`, true);
      }
    });
    $("emotion-switch").addEventListener("change", async (event) => {
      const on = event.target.checked;
      try {
        const reply = await post("/api/emotion/switch", { on });
        const done = `emotion system switched ${on ? "on" : "off"}`;
        say(reply.warning ? `${done}, but ${reply.warning}` : done, Boolean(reply.warning));
      } catch (error) {
        say(`not switched: ${error.message}`, true);
      }
    });
    $("graph-follow").addEventListener("change", (event) => {
      if (event.target.checked) followActive();
    });
    $("graph-search-form").addEventListener("submit", (event) => {
      event.preventDefault();
      search($("graph-search").value);
    });
    $("graph-expand").addEventListener("click", expandAll);
    $("graph-collapse").addEventListener("click", () => {
      if (dash.status.state) collapseAround(dash.status.state);
      else collapseAll();
    });
    document.querySelectorAll(".log-filters input").forEach((input) => input.addEventListener("input", renderLog));
    window.addEventListener("resize", scheduleDraw);
  }

  async function start() {
    wireControls();
    await Promise.all([loadGraph(), loadEmotions()]);
    connect();
    await refreshHealth();
    setInterval(refreshHealth, 1000);
    $("mark-form").addEventListener("submit", markNow);
    refreshRecorder();
    setInterval(refreshRecorder, 2000);
    refreshRoute();
    setInterval(scheduleDraw, 1000);
  }

  start();
})();
