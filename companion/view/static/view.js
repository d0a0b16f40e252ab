// companion view: draws the feed of /api/stream (Server-Sent Events) on an SVG map.
// World frame: metres north (n) and east (e) of the EKF origin; headings from north, clockwise.
"use strict";

const SVG_NS = "http://www.w3.org/2000/svg";
const STALE_S = 3;              // no new state for this long: say so
const FOLLOW_SPAN_M = 90;       // follow mode: this much of the world across the short side
const SIGMAS = 3;

const view = {
  state: null, info: null, est: [], tru: [], estEpoch: null, truEpoch: null,
  trueObstacles: [], trueShapes: [], truePose: null, updates: 0, lastSeq: null, lastNewAt: 0,
  orientation: null,            // "up" (north up) | "right" (north right); null: automatic
  follow: false, pending: false,
};
window.companionView = view;    // for the browser test and for curious operators

const $ = (id) => document.getElementById(id);
const map = $("map");

function applyPath(which, delta) {
  const epochKey = which === "est" ? "estEpoch" : "truEpoch";
  if (!delta) return;
  if (delta.from === 0 || view[epochKey] !== delta.epoch) view[which] = delta.points.slice();
  else view[which] = view[which].concat(delta.points);
  view[epochKey] = delta.epoch;
}

function onData(msg) {
  const seq = msg.state ? msg.state.seq : null;
  if (seq !== view.lastSeq || msg.info.finished) view.lastNewAt = performance.now();
  view.lastSeq = seq;
  view.state = msg.state;
  view.info = msg.info;
  view.trueObstacles = msg.true_obstacles || [];
  view.trueShapes = msg.true_shapes || [];
  view.truePose = msg.true_pose;
  applyPath("est", msg.estimated_path);
  applyPath("tru", msg.true_path);
  view.updates += 1;
  schedule();
}

function schedule() {
  if (view.pending) return;
  view.pending = true;
  requestAnimationFrame(() => { view.pending = false; render(); });
}

// ------------------------------------------------------------ geometry
function bounds() {
  const pts = [];
  const s = view.state;
  for (const p of view.est) pts.push(p);
  for (const p of view.tru) pts.push(p);
  for (const o of view.trueObstacles) {
    pts.push([o.north_m - o.radius_m, o.east_m - o.radius_m], [o.north_m + o.radius_m, o.east_m + o.radius_m]);
  }
  for (const shape of view.trueShapes) for (const p of shape.outline) pts.push(p);
  if (s) {
    const d = s.safety_distance_m || 0;
    for (const m of s.landmarks) pts.push([m.north_m - d, m.east_m - d], [m.north_m + d, m.east_m + d]);
    for (const m of s.movers) pts.push([m.north_m, m.east_m]);
    if (s.goal_ne_m) pts.push(s.goal_ne_m);
    if (s.pose) pts.push([s.pose.north_m, s.pose.east_m]);
  }
  if (!pts.length) return { n0: -50, n1: 50, e0: -50, e1: 50 };
  let n0 = Infinity, n1 = -Infinity, e0 = Infinity, e1 = -Infinity;
  for (const [n, e] of pts) {
    if (!isFinite(n) || !isFinite(e)) continue;
    n0 = Math.min(n0, n); n1 = Math.max(n1, n); e0 = Math.min(e0, e); e1 = Math.max(e1, e);
  }
  const pad = Math.max(8, 0.06 * Math.max(n1 - n0, e1 - e0));
  return { n0: n0 - pad, n1: n1 + pad, e0: e0 - pad, e1: e1 + pad };
}

function projection(width, height) {
  let b = bounds();
  const s = view.state;
  if (view.follow && s && s.pose) {
    const h = FOLLOW_SPAN_M / 2;
    b = { n0: s.pose.north_m - h, n1: s.pose.north_m + h, e0: s.pose.east_m - h, e1: s.pose.east_m + h };
  }
  const spanN = b.n1 - b.n0, spanE = b.e1 - b.e0;
  const scaleUp = Math.min(width / spanE, height / spanN);      // north up: e across, n up
  const scaleRight = Math.min(width / spanN, height / spanE);   // north right: n across, e down
  const orientation = view.orientation || (scaleRight > scaleUp * 1.05 ? "right" : "up");
  const k = orientation === "up" ? scaleUp : scaleRight;
  const cn = (b.n0 + b.n1) / 2, ce = (b.e0 + b.e1) / 2;
  const cx = width / 2, cy = height / 2;
  const pt = orientation === "up"
    ? (n, e) => [cx + (e - ce) * k, cy - (n - cn) * k]
    : (n, e) => [cx + (n - cn) * k, cy + (e - ce) * k];
  const vec = orientation === "up" ? (dn, de) => [de, -dn] : (dn, de) => [dn, de];
  return { pt, vec, k, orientation, b };
}

function ellipse(P, n, e, cov, cls) {
  // cov: [var_n, cov_ne, var_e] in m^2; SIGMAS-sigma ellipse.
  const [a, b, c] = cov;
  const mid = (a + c) / 2, r = Math.sqrt(((a - c) / 2) ** 2 + b * b);
  const l1 = Math.max(mid + r, 0), l2 = Math.max(mid - r, 0);
  const theta = 0.5 * Math.atan2(2 * b, a - c);
  const [dx, dy] = P.vec(Math.cos(theta), Math.sin(theta));
  const [x, y] = P.pt(n, e);
  const rx = Math.max(SIGMAS * Math.sqrt(l1) * P.k, 2), ry = Math.max(SIGMAS * Math.sqrt(l2) * P.k, 2);
  const deg = (Math.atan2(dy, dx) * 180) / Math.PI;
  return `<ellipse class="${cls}" cx="${f(x)}" cy="${f(y)}" rx="${f(rx)}" ry="${f(ry)}" transform="rotate(${f(deg)} ${f(x)} ${f(y)})"/>`;
}

const f = (v) => (Math.round(v * 10) / 10).toString();
const esc = (t) => String(t).replace(/[&<>"]/g, (ch) => ({ "&": "&amp;", "<": "&lt;", ">": "&gt;", '"': "&quot;" })[ch]);

function polyline(P, pts, cls) {
  if (pts.length < 2) return "";
  return `<polyline class="${cls}" points="${pts.map(([n, e]) => P.pt(n, e).map(f).join(",")).join(" ")}"/>`;
}

function arrow(x, y, dx, dy, len, head) {
  const norm = Math.hypot(dx, dy) || 1, ux = dx / norm, uy = dy / norm;
  const x2 = x + ux * len, y2 = y + uy * len;
  const bx = x2 - ux * head, by = y2 - uy * head;
  return `<line x1="${f(x)}" y1="${f(y)}" x2="${f(bx)}" y2="${f(by)}"/>` +
    `<path d="M${f(x2)},${f(y2)} L${f(bx - uy * head * 0.5)},${f(by + ux * head * 0.5)} L${f(bx + uy * head * 0.5)},${f(by - ux * head * 0.5)} Z"/>`;
}

function niceStep(metresPer80px) {
  const p = 10 ** Math.floor(Math.log10(metresPer80px));
  for (const m of [1, 2, 5, 10]) if (m * p >= metresPer80px) return m * p;
  return 10 * p;
}

// ------------------------------------------------------------ drawing
function gridSvg(P, width, height) {
  const step = niceStep(80 / P.k);
  const out = ['<g class="grid">'];
  const b = P.b;
  const extra = Math.max(width, height) / P.k;
  for (let n = Math.floor((b.n0 - extra) / step) * step; n <= b.n1 + extra; n += step) {
    const [x1, y1] = P.pt(n, b.e0 - extra), [x2, y2] = P.pt(n, b.e1 + extra);
    out.push(`<line x1="${f(x1)}" y1="${f(y1)}" x2="${f(x2)}" y2="${f(y2)}"/>`);
  }
  for (let e = Math.floor((b.e0 - extra) / step) * step; e <= b.e1 + extra; e += step) {
    const [x1, y1] = P.pt(b.n0 - extra, e), [x2, y2] = P.pt(b.n1 + extra, e);
    out.push(`<line x1="${f(x1)}" y1="${f(y1)}" x2="${f(x2)}" y2="${f(y2)}"/>`);
  }
  out.push("</g>");
  const label = P.orientation === "up" ? ["north \u2191", "east \u2192"] : ["north \u2192", "east \u2193"];
  out.push(`<text class="axis-label" x="${width - 8}" y="${height - 10}" text-anchor="end">${label[0]}   ${label[1]}   grid ${step} m</text>`);
  $("scale-bar").style.width = `${f(step * P.k)}px`;
  $("scale-text").textContent = `${step} m`;
  return out.join("");
}

function vehicleSvg(P, s) {
  const out = [];
  const { north_m: n, east_m: e, yaw_rad: yaw } = s.pose;
  const [x, y] = P.pt(n, e);
  const ring = 46;
  out.push(`<circle class="ring" cx="${f(x)}" cy="${f(y)}" r="${ring}"/>`);
  const width = (2 * Math.PI) / s.sectors;
  for (const k of s.blocked) {
    const h0 = k * width - width / 2, h1 = k * width + width / 2;
    const [ax, ay] = P.vec(Math.cos(h0), Math.sin(h0)), [bx, by] = P.vec(Math.cos(h1), Math.sin(h1));
    const r0 = 18, r1 = ring;
    out.push(`<path class="sector" d="M${f(x + ax * r0)},${f(y + ay * r0)} L${f(x + ax * r1)},${f(y + ay * r1)} ` +
      `L${f(x + bx * r1)},${f(y + by * r1)} L${f(x + bx * r0)},${f(y + by * r0)} Z"/>`);
  }
  out.push('<g class="vehicle">' + ellipse(P, n, e, s.pose.cov_m2, "cov"));
  const [hx, hy] = P.vec(Math.cos(yaw), Math.sin(yaw));
  const size = 9;
  out.push(`<path class="body" d="M${f(x + hx * size * 1.4)},${f(y + hy * size * 1.4)} L${f(x - hx * size + hy * size * 0.8)},${f(y - hy * size - hx * size * 0.8)} ` +
    `L${f(x - hx * size * 0.5)},${f(y - hy * size * 0.5)} L${f(x - hx * size - hy * size * 0.8)},${f(y - hy * size + hx * size * 0.8)} Z"/></g>`);
  if (s.command) {
    const h = s.command.heading_rad;
    const [dx, dy] = P.vec(Math.cos(h), Math.sin(h));
    out.push(`<g class="heading">${arrow(x, y, dx, dy, ring + 22, 10)}</g>`);
  }
  return out.join("");
}

function render() {
  const width = map.clientWidth || 800, height = map.clientHeight || 600;
  map.setAttribute("viewBox", `0 0 ${width} ${height}`);
  const P = projection(width, height);
  const s = view.state;
  const out = [gridSvg(P, width, height)];
  for (const o of view.trueObstacles) {
    const [x, y] = P.pt(o.north_m, o.east_m);
    out.push(`<g class="true-obstacle" data-id="${esc(o.id)}"><circle class="body" cx="${f(x)}" cy="${f(y)}" r="${f(Math.max(o.radius_m * P.k, 3))}"/></g>`);
  }
  for (const shape of view.trueShapes) {
    const d = shape.outline.map(([n, e], i) => { const [x, y] = P.pt(n, e); return `${i ? "L" : "M"}${f(x)},${f(y)}`; }).join(" ");
    out.push(`<g class="true-shape" data-id="${esc(shape.id)}" data-kind="${esc(shape.kind)}"><path class="body" d="${d} Z"/></g>`);
  }
  out.push(polyline(P, view.tru, "true-path"));
  out.push(polyline(P, view.est, "est-path"));
  if (s) {
    if (s.goal_ne_m) {
      const [x, y] = P.pt(s.goal_ne_m[0], s.goal_ne_m[1]);
      const r = Math.max((s.goal_radius_m || 1) * P.k, 6);
      out.push(`<g class="goal"><circle cx="${f(x)}" cy="${f(y)}" r="${f(r)}"/><path d="M${f(x)},${f(y - 7)} L${f(x + 7)},${f(y)} L${f(x)},${f(y + 7)} L${f(x - 7)},${f(y)} Z"/></g>`);
    }
    for (const m of s.landmarks) {
      const [x, y] = P.pt(m.north_m, m.east_m);
      const d = (s.safety_distance_m || 0) * P.k;
      out.push(`<g class="landmark" data-id="${esc(m.id)}"><circle class="safety" cx="${f(x)}" cy="${f(y)}" r="${f(d)}"/>` +
        ellipse(P, m.north_m, m.east_m, m.cov_m2, "cov") +
        `<line class="centre" x1="${f(x - 5)}" y1="${f(y)}" x2="${f(x + 5)}" y2="${f(y)}"/><line class="centre" x1="${f(x)}" y1="${f(y - 5)}" x2="${f(x)}" y2="${f(y + 5)}"/>` +
        (m.id !== null ? `<text x="${f(x + 7)}" y="${f(y - 7)}">${esc(m.id)}</text>` : "") + "</g>");
    }
    for (const m of s.movers) {
      const [x, y] = P.pt(m.north_m, m.east_m);
      const [dx, dy] = P.vec(m.vel_north_mps, m.vel_east_mps);
      const len = Math.hypot(m.vel_north_mps, m.vel_east_mps) * 2 * P.k;
      out.push(`<g class="mover" data-id="${esc(m.track_id)}">` + ellipse(P, m.north_m, m.east_m, m.cov_m2, "cov") +
        (len > 2 ? arrow(x, y, dx, dy, len, Math.min(9, len / 2)) : "") + "</g>");
    }
  }
  if (view.truePose) {
    const [x, y] = P.pt(view.truePose.north_m, view.truePose.east_m);
    out.push(`<circle class="true-vehicle" cx="${f(x)}" cy="${f(y)}" r="4.5"/>`);
  }
  if (s && s.pose) out.push(vehicleSvg(P, s));
  map.innerHTML = out.join("");
  map.dataset.landmarks = s ? s.landmarks.length : 0;
  map.dataset.movers = s ? s.movers.length : 0;
  map.dataset.trueObstacles = view.trueObstacles.length;
  map.dataset.trueShapes = view.trueShapes.length;
  map.dataset.updates = view.updates;
  map.dataset.seq = s ? s.seq : "";           // the datagram this drawing shows
  $("rotate").textContent = P.orientation === "up" ? "north \u2191" : "north \u2192";
  panel(s);
}

function setChip(el, text, kind) {
  el.textContent = text;
  el.className = `chip chip-${kind}`;
}

function panel(s) {
  const info = view.info || {};
  $("source").textContent = `${info.source || "?"} (${info.datagrams || 0} updates${info.refused ? `, ${info.refused} refused` : ""})`;
  if (!s) return;
  const est = s.estimator || "starting";
  setChip($("estimator"), est, { ok: "ok", degraded: "degraded", lost: "lost" }[est] || "wait");
  $("sigma").textContent = s.radius_2sigma_m != null ? `2\u03c3 ${s.radius_2sigma_m.toFixed(2)} m` : "";
  const phase = [s.phase || "?", s.armed ? "armed" : "disarmed", s.guided ? "GUIDED" : "not GUIDED"];
  if (s.arrived) phase.push("arrived");
  $("phase").textContent = phase.join(", ");
  const c = s.command;
  let decision = c ? `${c.mode}, heading ${deg(c.heading_rad)}\u00b0 at ${c.speed_mps.toFixed(1)} m/s` : "\u2013";
  if (s.safe_action) decision += ` \u2014 safe action: ${s.safe_action}`;
  decision += `; ${s.blocked.length} of ${s.sectors} sectors blocked`;
  $("decision").textContent = decision;
  $("pose").textContent = s.pose ? `${s.pose.north_m.toFixed(1)} N, ${s.pose.east_m.toFixed(1)} E, yaw ${deg(s.pose.yaw_rad)}\u00b0` : "\u2013";
  $("goal").textContent = s.goal_ne_m ? `${s.goal_ne_m[0].toFixed(1)} N, ${s.goal_ne_m[1].toFixed(1)} E` +
    (s.pose ? ` (${Math.hypot(s.goal_ne_m[0] - s.pose.north_m, s.goal_ne_m[1] - s.pose.east_m).toFixed(1)} m)` : "") : "none";
  $("mapcount").textContent = `${s.landmarks.length} landmarks, ${s.movers.length} movers` +
    (s.landmarks_left_out ? ` (${s.landmarks_left_out} far ones not sent)` : "");
  $("time").textContent = s.t_s != null ? `${s.t_s.toFixed(1)} s` : "\u2013";
}

const deg = (rad) => (((rad * 180) / Math.PI + 360) % 360).toFixed(0);

function linkStatus() {
  const el = $("link");
  if (!view.info) return;
  const age = (performance.now() - view.lastNewAt) / 1000;
  if (view.info.finished) setChip(el, "replay ended", "wait");
  else if (!view.state) setChip(el, "waiting for data", "wait");
  else if (age > STALE_S) setChip(el, `no data ${age.toFixed(0)} s`, "stale");
  else setChip(el, "live", "ok");
}

function connect() {
  const source = new EventSource("/api/stream");
  source.onmessage = (event) => { onData(JSON.parse(event.data)); linkStatus(); };
  source.onerror = () => setChip($("link"), "reconnecting", "stale");   // EventSource retries
}

$("rotate").addEventListener("click", () => {
  const now = projection(map.clientWidth || 800, map.clientHeight || 600).orientation;
  view.orientation = now === "up" ? "right" : "up";
  schedule();
});
$("follow").addEventListener("click", (event) => {
  view.follow = !view.follow;
  event.currentTarget.setAttribute("aria-pressed", String(view.follow));
  schedule();
});
window.addEventListener("resize", schedule);
setInterval(linkStatus, 1000);
connect();
render();
