// streamseg live view: plain JavaScript, no build step, no external resources.
// The server (streamseg/view/server.py) sends coalesced "rows" (list health) and "timeline"
// (the open stream's cuts, segments, repetitions) messages over one WebSocket.
"use strict";

const ROW_H = 46;  // px, fixed so the list can be virtual (only visible rows are in the DOM)
const LEFT = 122;  // px of lane titles
const LANES = {human: [8, 40], seg: [52, 84], cut: [96, 134], rep: [146, 172]};
const AXIS_Y = 184;
const SVG_NS = "http://www.w3.org/2000/svg";
const PALETTE = ["#1f77b4", "#ff7f0e", "#2ca02c", "#d62728", "#9467bd", "#8c564b", "#e377c2",
                 "#17becf", "#bcbd22", "#7f7f7f"];

const $ = (id) => document.getElementById(id);
const rows = new Map();   // stream id -> list row from the server
let order = [];           // sorted stream ids
let header = {};
let clockOffset = 0;      // server clock - this page's clock (s)
let ws = null;
let open = null;          // the open stream: {id, fps, frame, cuts, segments, reps, human, ...}
const trace = new URLSearchParams(location.search).has("trace") ? [] : null;
window.viewTrace = trace;  // benchmarks/view_latency.py reads when updates reached the DOM
window.viewBusyMs = 0;     // and how long this page's script spent on the updates

function nowMs() { return performance.timeOrigin + performance.now(); }
function esc(s) {
  return String(s).replace(/[&<>"']/g, (c) => ({"&": "&amp;", "<": "&lt;", ">": "&gt;",
                                                '"': "&quot;", "'": "&#39;"}[c]));
}
function colour(label) {
  if (label < PALETTE.length) return PALETTE[label];
  return `hsl(${(label * 137.508) % 360}, 55%, 48%)`;  // golden angle: distinct, stable per id
}
function fmt(v, digits = 1, unit = "") {
  return v === null || v === undefined ? "–" : `${Number(v).toFixed(digits)}${unit}`;
}
function ago(at) {
  if (at === null || at === undefined) return "–";
  const s = Math.max(0, Date.now() / 1000 + clockOffset - at);
  return s < 60 ? `${s.toFixed(1)} s ago` : `${Math.floor(s / 60)} min ago`;
}
function errText(errors) {
  const parts = Object.entries(errors || {}).map(([k, n]) => `${k}×${n}`);
  return parts.length ? parts.join(", ") : "none";
}
function svg(tag, attrs) {
  const el = document.createElementNS(SVG_NS, tag);
  for (const [k, v] of Object.entries(attrs)) el.setAttribute(k, v);
  return el;
}

// --- connection ------------------------------------------------------------------------------

function connect() {
  const conn = $("conn");
  ws = new WebSocket((location.protocol === "https:" ? "wss://" : "ws://") + location.host + "/ws");
  ws.onopen = () => {
    conn.dataset.state = "open";
    conn.textContent = "connected";
    if (header) applyHeader(header);  // what the view server last said of the daemon
    if (open) send({op: "open", stream: open.id});
  };
  ws.onclose = () => {
    conn.dataset.state = "closed";
    conn.textContent = "disconnected: retrying";
    setTimeout(connect, 1000);
  };
  ws.onmessage = (m) => {
    const start = trace ? performance.now() : 0;
    const msg = JSON.parse(m.data);
    if (msg.header) applyHeader(msg.header);
    if (msg.t === "rows") applyRows(msg);
    else if (msg.t === "timeline") applyTimeline(msg);
    if (trace) window.viewBusyMs += performance.now() - start;
  };
}
function send(obj) { if (ws && ws.readyState === 1) ws.send(JSON.stringify(obj)); }

function applyHeader(h) {
  header = h;
  clockOffset = h.now - Date.now() / 1000;
  const lat = h.latency_p50_ms === null || h.latency_p50_ms === undefined ? "" :
    ` · daemon latency p50 ${fmt(h.latency_p50_ms, 1)} ms, p99 ${fmt(h.latency_p99_ms, 1)} ms`;
  const daemon = h.connected === false ? " · control endpoint not answering" : "";
  $("totals").textContent = `${h.streams} streams, ${h.open} open · ${h.applied} events${lat}` +
    ` · ${h.publish}${daemon}`;
  // the page reaches the view server; say whether the view server reaches the daemon
  const conn = $("conn");
  if (ws && ws.readyState === 1) {
    conn.dataset.state = h.daemon === false ? "nodaemon" : "open";
    conn.textContent = h.daemon === false ? `no daemon at ${h.publish}: waiting for it` :
      "connected";
  }
}

// --- the list ---------------------------------------------------------------------------------

function applyRows(msg) {
  if (msg.all) { rows.clear(); order = []; }
  for (const id of msg.removed || []) {  // closed streams the server no longer keeps
    if (!rows.has(id)) continue;
    rows.delete(id);
    order.splice(order.indexOf(id), 1);
  }
  const t = trace ? nowMs() : 0;
  let openChanged = false;
  for (const r of msg.rows) {
    if (!rows.has(r.stream)) insertSorted(r.stream);
    rows.set(r.stream, r);
    if (trace) trace.push([r.stream, "row", r.cuts, t]);
    if (open && r.stream === open.id) openChanged = true;
  }
  renderList();
  if (openChanged) { renderHealth(); renderViewport(); }
  if (!open) {
    const want = decodeURIComponent((location.hash.match(/stream=([^&]+)/) || [])[1] || "");
    if (want && rows.has(want)) openStream(want);
    else if (!want && rows.size) openStream(newest());
  }
}
// the stream to open when none is asked for: the newest open one (else the newest closed one)
function newest() {
  let best = null;
  for (const r of rows.values()) {
    const key = [r.closed ? 0 : 1, r.created || 0];
    if (!best || key[0] > best.key[0] || (key[0] === best.key[0] && key[1] > best.key[1]))
      best = {key, id: r.stream};
  }
  return best.id;
}
function insertSorted(id) {
  let lo = 0, hi = order.length;
  while (lo < hi) { const mid = (lo + hi) >> 1; if (order[mid] < id) lo = mid + 1; else hi = mid; }
  order.splice(lo, 0, id);
}
function visibleIds() {
  const f = $("filter").value.trim().toLowerCase();
  return f ? order.filter((id) => id.toLowerCase().includes(f)) : order;
}
const rowEls = new Map();  // stream id -> {el, html}: rows in the DOM, rewritten when changed
function rowHtml(r) {
  const closed = r.closed ? ` data-closed="${esc(r.closed)}"` : "";
  const nerr = Object.values(r.errors || {}).reduce((a, b) => a + b, 0);
  const sel = open && open.id === r.stream ? " sel" : "";
  const fill = r.buffer_fill === null ? 0 : Math.round(r.buffer_fill * 100);
  const state = r.closed ? `closed (${esc(r.closed)})` : `${fmt(r.fps_in, 0)} f/s in`;
  const act = r.action ? `<span class="sw" style="background:${colour(r.action[0])}"></span>` +
    `id ${r.action[0]}` : "";
  const reps = r.reps !== null ? ` · ${r.reps} reps` : "";
  const last = r.last ? `${esc(r.last.type)} ${ago(r.last.at)}` : "no event yet";
  return {cls: `row${sel}${nerr ? " err" : ""}`, closed: r.closed,
          html: `<div><span class="dot"></span><span class="name">` +
    `${esc(r.stream)}</span> <span class="meta">${state} · ${act}${reps}</span></div>` +
    `<div class="meta">lag ${fmt(r.lag, 2, " s")} · buffer <span class="fill"><i ` +
    `style="width:${fill}%"></i></span> ${fill}% · ${r.cuts} cuts · errors ` +
    `${nerr ? esc(errText(r.errors)) : "0"} · ${last}</div>`};
}
function renderList() {
  const ids = visibleIds();
  const list = $("list"), spacer = $("spacer");
  spacer.style.height = `${ids.length * ROW_H}px`;
  const top = list.scrollTop, h = list.clientHeight || 600;
  const a = Math.max(0, Math.floor(top / ROW_H) - 3);
  const b = Math.min(ids.length, Math.ceil((top + h) / ROW_H) + 3);
  const keep = new Set();
  for (let i = a; i < b; i++) {
    const id = ids[i];
    keep.add(id);
    const want = rowHtml(rows.get(id));
    let item = rowEls.get(id);
    if (!item) {
      const el = document.createElement("div");
      el.dataset.stream = id;
      spacer.appendChild(el);
      item = {el, html: null};
      rowEls.set(id, item);
    }
    const el = item.el;
    el.style.top = `${i * ROW_H}px`;
    if (el.className !== want.cls) el.className = want.cls;
    if (want.closed) el.dataset.closed = want.closed; else delete el.dataset.closed;
    if (item.html !== want.html) { el.innerHTML = want.html; item.html = want.html; }
  }
  for (const [id, item] of rowEls)
    if (!keep.has(id)) { item.el.remove(); rowEls.delete(id); }
  const nOpen = order.filter((id) => !rows.get(id).closed).length;
  $("count").textContent = order.length ?
    `${order.length} streams (${nOpen} open)` + (ids.length !== order.length ?
      `, ${ids.length} shown` : "") : "no streams yet";
}

// --- the open stream --------------------------------------------------------------------------

function openStream(id) {
  open = {id, fps: null, frame: 0, cuts: [], segments: [], reps: [], human: null, segRange: null,
          closed: null, cutEls: []};
  for (const layer of ["human-layer", "seg-layer", "cut-layer", "rep-layer", "names"])
    $(layer).replaceChildren();
  $("empty").hidden = true;
  $("open").hidden = false;
  $("title").textContent = id;
  history.replaceState(null, "", `#stream=${encodeURIComponent(id)}`);
  send({op: "open", stream: id});
  renderList();
  renderHealth();
  renderViewport();
}

function applyTimeline(tl) {
  if (!open || tl.stream !== open.id) return;
  if (tl.row) rows.set(tl.stream, tl.row);
  if (tl.full) {
    open.cuts = []; open.reps = []; open.cutEls = [];
    for (const layer of ["human-layer", "seg-layer", "cut-layer", "rep-layer"])
      $(layer).replaceChildren();
  }
  open.fps = tl.fps || open.fps;
  open.frame = Math.max(open.frame, tl.frame || 0);
  open.closed = tl.closed;
  open.segRange = tl.seg_range;
  const t = trace ? nowMs() : 0;
  const cutLayer = $("cut-layer");
  const [y0, y1] = LANES.cut;
  for (const c of tl.cuts) {
    const el = svg("line", {class: "cut", x1: c.frame, x2: c.frame, y1: y0, y2: y1,
                            "vector-effect": "non-scaling-stroke", "data-frame": c.frame,
                            "data-emitted": c.emitted_at});
    const title = svg("title", {});
    title.textContent = `cut at frame ${c.frame} (emitted at ${c.emitted_at}, ` +
      `score ${Number(c.score).toFixed(2)}), provisional`;
    el.appendChild(title);
    cutLayer.appendChild(el);
    open.cuts.push(c);
    open.cutEls.push(el);
    if (trace) trace.push([tl.stream, "cut", c.frame, t]);
  }
  const repLayer = $("rep-layer");
  for (const [a, b, n] of tl.reps) {
    const el = svg("rect", {class: "rep", x: a, width: Math.max(1, b - a), y: LANES.rep[0],
                            height: LANES.rep[1] - LANES.rep[0], "vector-effect": "non-scaling-stroke",
                            "data-start": a, "data-end": b, "data-count": n});
    repLayer.appendChild(el);
    open.reps.push([a, b, n]);
  }
  if (tl.segments) {
    open.segments = tl.segments;
    const layer = $("seg-layer");
    const frag = document.createDocumentFragment();
    for (const [a, b, lab] of tl.segments) {
      const el = svg("rect", {class: "seg", x: a, width: b - a, y: LANES.seg[0],
                              height: LANES.seg[1] - LANES.seg[0], fill: colour(lab),
                              "data-start": a, "data-end": b, "data-label": lab});
      const title = svg("title", {});
      title.textContent = `frames ${a}–${b}: action id ${lab}`;
      el.appendChild(title);
      frag.appendChild(el);
    }
    layer.replaceChildren(frag);
  }
  if (tl.human) open.human = tl.human;
  const end = open.segRange ? open.segRange[1] : -1;  // cuts a relabel has superseded
  open.cuts.forEach((c, i) => open.cutEls[i].classList.toggle("old", c.frame < end));
  if (tl.human || tl.segments) renderHuman();
  renderHealth();
  renderKey();
  renderViewport();
}

function humanColours() {
  // each human action takes the colour of the id matched to it: same colour = agreement
  const out = {};
  const row = rows.get(open.id);
  const match = row && row.agreement ? row.agreement.match : {};
  for (const [id, name] of Object.entries(match)) out[name] = colour(Number(id));
  return out;
}
function renderHuman() {
  const layer = $("human-layer");
  if (!open.human) { layer.replaceChildren(); return; }
  const cols = humanColours();
  const frag = document.createDocumentFragment();
  for (const [a, b, name] of open.human) {
    const el = svg("rect", {class: "human", x: a, width: b - a, y: LANES.human[0],
                            height: LANES.human[1] - LANES.human[0], fill: cols[name] || "#bbb",
                            "vector-effect": "non-scaling-stroke", "data-start": a, "data-end": b,
                            "data-name": name});
    const title = svg("title", {});
    title.textContent = `human label: ${name}, frames ${a}–${b}`;
    el.appendChild(title);
    frag.appendChild(el);
  }
  layer.replaceChildren(frag);
}

function renderHealth() {
  if (!open) return;
  const r = rows.get(open.id) || {};
  const status = $("status");
  if (r.closed) { status.dataset.closed = r.closed; status.textContent = `closed (${r.closed})`; }
  else { delete status.dataset.closed; status.textContent = "live"; }
  const fps = r.fps || open.fps;
  const items = [
    ["frames/s in", fmt(r.fps_in, 1)], ["lag (cut decided)", fmt(r.lag, 2, " s")],
    ["buffer fill", r.buffer_fill === null || r.buffer_fill === undefined ? "–" :
      `${Math.round(r.buffer_fill * 100)}%`],
    ["frame", `${r.frame ?? 0}` + (fps ? ` (${((r.frame ?? 0) / fps).toFixed(1)} s)` : "")],
    ["fps", fmt(fps, 0)], ["relabel revision", `${r.revision ?? 0}`], ["cuts", `${r.cuts ?? 0}`],
    ["gaps", `${r.gaps ?? 0}`], ["errors", errText(r.errors)],
    ["last event", r.last ? `${r.last.type}, ${ago(r.last.at)}` : "–"],
  ];
  $("health").innerHTML = items.map(([k, v]) =>
    `<div><dt>${esc(k)}</dt><dd data-k="${esc(k)}">${esc(v)}</dd></div>`).join("");
  const match = r.agreement ? r.agreement.match : {};
  if (r.action) {
    const [lab, since] = r.action;
    const name = match[String(lab)] ? ` ≈ ${esc(match[String(lab)])}` : "";
    const newer = open.cuts.filter((c) => c.frame > Math.max(since, open.segRange ?
      open.segRange[1] - 1 : -1));
    const prov = newer.length ? ` · provisional cut at frame ${newer[newer.length - 1].frame}` : "";
    $("action").innerHTML = `now: <span class="sw" style="background:${colour(lab)}"></span>` +
      `<b data-label="${lab}">id ${lab}</b>${name} since frame ${since}${prov}`;
  } else {
    $("action").textContent = "now: no relabel yet";
  }
  $("reps").innerHTML = r.reps !== null && r.reps !== undefined ?
    `set: <b id="rep-count">${r.reps}</b> repetitions` : "";
  const ag = r.agreement;
  $("agreement").textContent = r.labels_error ? r.labels_error : ag ?
    `agreement with the human labels so far: frame accuracy ` +
    `${ag.frame_accuracy === null ? "–" : ag.frame_accuracy.toFixed(2)} over ${ag.frames} frames` +
    (ag.cut_recall === null ? "" : ` · human boundaries found by a cut ` +
      `${Math.round(ag.cut_recall * ag.boundaries)}/${ag.boundaries}`) : "";
  if (open.human) renderHuman();
}

function renderKey() {
  const r = rows.get(open.id) || {};
  const match = r.agreement ? r.agreement.match : {};
  const ids = [...new Set(open.segments.map((s) => s[2]))].sort((a, b) => a - b);
  const cur = r.action ? r.action[0] : null;
  $("key").innerHTML = ids.map((id) =>
    `<span class="${id === cur ? "cur" : ""}" data-label="${id}"><span class="sw" ` +
    `style="background:${colour(id)}"></span>id ${id}` +
    `${match[String(id)] ? ` ≈ ${esc(match[String(id)])}` : ""}</span>`).join("") +
    (open.human ? `<span><span class="sw" style="background:#bbb"></span>human action no id ` +
      `matches</span>` : "");
}

// --- drawing: one transform places every frame-coordinate element -------------------------------

function viewport() {
  const fps = open.fps || 120;
  const frame = Math.max(open.frame, (rows.get(open.id) || {}).frame || 0, 1);
  const win = Number($("window").value);
  if (!win) return [0, frame * 1.02];
  const span = win * fps;
  const top = Math.max(frame + span * 0.03, span);
  if ($("follow").checked) return [top - span, top];
  const f1 = span + (top - span) * Number($("pan").value) / 1000;
  return [f1 - span, f1];
}
function renderViewport() {
  if (!open) return;
  const el = $("timeline");
  const width = el.clientWidth || 800;
  const [f0, f1] = viewport();
  const k = (width - LEFT - 8) / Math.max(1, f1 - f0);
  $("world").setAttribute("transform", `matrix(${k} 0 0 1 ${LEFT - f0 * k} 0)`);
  const clip = $("clip-rect");
  clip.setAttribute("x", LEFT); clip.setAttribute("y", 0);
  clip.setAttribute("width", width - LEFT); clip.setAttribute("height", AXIS_Y);
  const nowLine = $("now-line");
  const frame = Math.max(open.frame, (rows.get(open.id) || {}).frame || 0);
  nowLine.setAttribute("x1", frame); nowLine.setAttribute("x2", frame);
  nowLine.setAttribute("y2", AXIS_Y);
  const future = $("future");  // the human labels ahead of the stream, greyed
  future.setAttribute("x", frame);
  future.setAttribute("width", open.human && !open.closed ?
    Math.max(0, open.human[open.human.length - 1][1] - frame) : 0);
  const titles = $("lane-titles");
  if (!titles.childElementCount) {
    const names = {human: "human labels", seg: "relabelled (id)", cut: "provisional cuts",
                   rep: "repetitions"};
    for (const [lane, [y0, y1]] of Object.entries(LANES)) {
      titles.appendChild(svg("rect", {class: "lane-bg", x: LEFT, y: y0, width: 10000,
                                      height: y1 - y0}));
      const t = svg("text", {class: "lane-title", x: 6, y: (y0 + y1) / 2 + 4});
      t.textContent = names[lane];
      titles.appendChild(t);
    }
  }
  // names of wide-enough blocks, in screen coordinates (text must not be stretched)
  const namesG = $("names");
  const frag = document.createDocumentFragment();
  const label = (a, b, text, y) => {
    const px = (Math.min(b, f1) - Math.max(a, f0)) * k;
    if (px < text.length * 7 + 6) return;
    const t = svg("text", {x: LEFT + ((Math.max(a, f0) + Math.min(b, f1)) / 2 - f0) * k, y,
                           "text-anchor": "middle"});
    t.textContent = text;
    frag.appendChild(t);
  };
  for (const [a, b, name] of open.human || []) if (b > f0 && a < f1) label(a, b, name, 28);
  for (const [a, b, lab] of mergedRuns(open.segments))
    if (b > f0 && a < f1) label(a, b, `id ${lab}`, 72);
  namesG.setAttribute("class", "names");
  namesG.replaceChildren(frag);
  renderAxis(f0, f1, k, width);
  const pan = $("pan");
  pan.disabled = $("follow").checked || !Number($("window").value);
}
function mergedRuns(segs) {
  const out = [];
  for (const [a, b, lab] of segs) {
    const last = out[out.length - 1];
    if (last && last[2] === lab && last[1] === a) last[1] = b; else out.push([a, b, lab]);
  }
  return out;
}
function renderAxis(f0, f1, k, width) {
  const fps = open.fps || 120;
  const steps = [0.5, 1, 2, 5, 10, 15, 30, 60, 120, 300, 600, 1200, 3600];
  const pxPerS = k * fps;
  const step = steps.find((s) => s * pxPerS >= 70) || 3600;
  const axis = $("axis");
  const frag = document.createDocumentFragment();
  for (let s = Math.ceil(f0 / fps / step) * step; s * fps <= f1; s += step) {
    const x = LEFT + (s * fps - f0) * k;
    if (x < LEFT || x > width) continue;
    frag.appendChild(svg("line", {class: "tick", x1: x, x2: x, y1: 4, y2: AXIS_Y + 4}));
    const t = svg("text", {class: "tick-label", x, y: AXIS_Y + 16, "text-anchor": "middle"});
    t.textContent = `${s >= 60 ? `${Math.floor(s / 60)}:${String(s % 60).padStart(2, "0")}` :
      `${s} s`}`;
    frag.appendChild(t);
  }
  const t = svg("text", {class: "tick-label", x: 6, y: AXIS_Y + 16});
  t.textContent = "stream time";
  frag.appendChild(t);
  axis.replaceChildren(frag);
}

// --- wiring ---------------------------------------------------------------------------------------

// pointerdown, not click: a row rewritten between press and release would lose the click
$("spacer").addEventListener("pointerdown", (e) => {
  const row = e.target.closest(".row");
  if (row) openStream(row.dataset.stream);
});
$("list").addEventListener("scroll", renderList);
$("filter").addEventListener("input", () => { $("list").scrollTop = 0; renderList(); });
$("window").addEventListener("change", renderViewport);
$("follow").addEventListener("change", renderViewport);
$("pan").addEventListener("input", renderViewport);
$("timeline").addEventListener("wheel", (e) => {  // wheel pans back in time
  if (!open) return;
  e.preventDefault();
  $("follow").checked = false;
  const pan = $("pan");
  pan.value = Math.min(1000, Math.max(0, Number(pan.value) + (e.deltaY > 0 ? 20 : -20)));
  renderViewport();
}, {passive: false});
window.addEventListener("resize", renderViewport);
window.addEventListener("hashchange", () => {
  const want = decodeURIComponent((location.hash.match(/stream=([^&]+)/) || [])[1] || "");
  if (want && (!open || open.id !== want)) openStream(want);
});
setInterval(() => { renderList(); if (open) renderHealth(); }, 1000);  // ages tick
connect();
